"""The browser renderer: an aiohttp bridge (server.py) and the page it serves (static/)."""
