"""Calls MCP tools over streamable HTTP with the official Python client (PyPI `mcp`) and prints
one JSON list with each answer, for api/tests/conformance.rs to compare with the other adapters.

usage: mcp_calls.py http://HOST:PORT/mcp CALLS_JSON [--token TOKEN]
  CALLS_JSON: [[name, arguments], ...]
  prints: [{"is_error": bool, "value": structured content or null, "text": str}, ...]
"""
import asyncio
import json
import sys

from mcp import ClientSession
from mcp.client.streamable_http import streamable_http_client
from mcp.shared._httpx_utils import create_mcp_http_client


def attr(obj, snake, camel):
    return getattr(obj, snake, getattr(obj, camel, None))


async def main(url, calls, token):
    out = []
    headers = {"Authorization": "Bearer " + token} if token else {}
    async with create_mcp_http_client(headers=headers) as http:
        async with streamable_http_client(url, http_client=http) as (read, write):
            async with ClientSession(read, write) as session:
                await asyncio.wait_for(session.initialize(), 30)
                for name, args in calls:
                    r = await asyncio.wait_for(session.call_tool(name, args), 120)
                    text = "".join(getattr(c, "text", "") for c in (r.content or []))
                    out.append({
                        "is_error": bool(attr(r, "is_error", "isError")),
                        "value": attr(r, "structured_content", "structuredContent"),
                        "text": text,
                    })
    print(json.dumps(out))


if __name__ == "__main__":
    token = sys.argv[sys.argv.index("--token") + 1] if "--token" in sys.argv else None
    asyncio.run(main(sys.argv[1], json.loads(sys.argv[2]), token))
