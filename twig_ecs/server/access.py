"""Who may use a server: the token clients send first (``auth``), checked before serving.

Apart from the server so that ``twig``'s parser need not import asyncio.
"""

from __future__ import annotations

from twig_ecs.errors import TwigError

#: Environment variable a token can come from (kept out of ``ps`` listings).
TOKEN_ENV = "TWIG_TOKEN"


def check_token(token: str | None) -> None:
    """Refuse a token no client could send (TwigError saying why): auth's token is a string
    of at most 200 characters (``twig_ecs.arguments.MAX_TEXT``), valid Unicode."""
    from twig_ecs.arguments import MAX_TEXT  # here: the parser imports this module for every command

    if token is None:
        return
    if len(token) > MAX_TEXT:
        raise TwigError(f"the token is {len(token)} characters long: clients send it with auth, which takes "
                        f"at most {MAX_TEXT}; choose a shorter one (--token or {TOKEN_ENV})")  # fmt: skip
    try:
        token.encode("utf-8")
    except UnicodeEncodeError:
        raise TwigError(f"the token is not valid UTF-8 text, so no client could send it; choose another "
                        f"(--token or {TOKEN_ENV})") from None  # fmt: skip
