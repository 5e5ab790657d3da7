"""Server mode: an asynchronous JSON-RPC command interface for a drama manager (SPEC 6)."""
