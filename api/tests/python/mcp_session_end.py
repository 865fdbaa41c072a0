"""Runs one MCP session over streamable HTTP with the official Python client (PyPI `mcp`):
initialize, call an unknown tool (a JSON-RPC error), then end the session; prints one JSON
object with the error code the client saw and every warning the client logged, for
api/tests/attack.rs (the client logs "Session termination failed" unless the server answers
the DELETE with 200 or 204).

usage: mcp_session_end.py http://HOST:PORT/mcp
"""
import asyncio
import json
import logging
import sys

from mcp import ClientSession
from mcp.client.streamable_http import streamable_http_client
from mcp.shared.exceptions import MCPError


class Collect(logging.Handler):
    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


async def main(url):
    handler = Collect()
    logging.getLogger().addHandler(handler)
    logging.getLogger().setLevel(logging.WARNING)
    code = None
    async with streamable_http_client(url) as (read, write, *_):
        async with ClientSession(read, write) as session:
            await asyncio.wait_for(session.initialize(), 30)
            try:
                await asyncio.wait_for(session.call_tool("no_such_tool", {}), 30)
            except MCPError as e:
                code = e.error.code
    print(json.dumps({"unknown_tool_code": code, "warnings": handler.messages}))


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1]))
