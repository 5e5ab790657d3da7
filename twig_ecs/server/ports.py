"""The server's default ports, apart from the server so ``twig``'s parser need not import asyncio."""

#: JSON-RPC port of ``twig serve``.
DEFAULT_PORT = 7470
#: Port of the Twig line protocol when ``--twig`` names none.
DEFAULT_TWIG_PORT = 10001
