"""Drives `opengraph mcp` with the official MCP Python client (PyPI `mcp`) over stdio and
prints one JSON object with what it saw, for api/tests/mcp.rs to check.

usage: mcp_client.py OPENGRAPH_BINARY MAP [--allow-writes]
"""
import asyncio
import json
import sys

from mcp import ClientSession, StdioServerParameters
from mcp.client.stdio import stdio_client


def attr(obj, snake, camel):
    """mcp 2.x names fields in snake_case; 1.x in camelCase."""
    return getattr(obj, snake, getattr(obj, camel, None))


def content(result):
    """(is_error, structured content or parsed text, text)."""
    text = "".join(getattr(c, "text", "") for c in (result.content or []))
    structured = attr(result, "structured_content", "structuredContent")
    if structured is None:
        try:
            structured = json.loads(text)
        except ValueError:
            structured = None
    return bool(attr(result, "is_error", "isError")), structured, text


async def main(binary, db, extra):
    params = StdioServerParameters(command=binary, args=["mcp", "--db", db, *extra])
    out = {}
    async with stdio_client(params) as (read, write):
        async with ClientSession(read, write) as session:
            init = await asyncio.wait_for(session.initialize(), 30)
            out["server"] = attr(init, "server_info", "serverInfo").name
            tools = await asyncio.wait_for(session.list_tools(), 30)
            out["tools"] = sorted(t.name for t in tools.tools)
            out["schemas"] = {t.name: attr(t, "input_schema", "inputSchema") for t in tools.tools}

            async def call(name, args):
                r = await asyncio.wait_for(session.call_tool(name, args), 120)
                err, value, text = content(r)
                return {"is_error": err, "value": value, "text": text}

            out["find"] = await call("find_objects", {"text": "the bench near the bus stop", "k": 3})
            out["cypher"] = await call(
                "read_cypher",
                {"query": "MATCH (s:Segment) RETURN count(s) AS n"},
            )
            out["cypher_write_refused"] = await call(
                "read_cypher", {"query": "CREATE (n:Hack) RETURN n"}
            )
            out["locate"] = await call(
                "locate", {"text": "I'm at a T-junction next to a traffic light"}
            )
            out["bad_args"] = await call("find_objects", {"k": 3})
            try:
                r = await asyncio.wait_for(
                    session.call_tool("write_cypher", {"query": "CREATE (n:Hack {x: 1})"}), 30
                )
                err, value, text = content(r)
                out["write"] = {"is_error": err, "value": value, "text": text}
            except Exception as e:  # a JSON-RPC error: the tool is not offered
                out["write"] = {"protocol_error": str(e)}
            out["after_write"] = await call(
                "read_cypher", {"query": "MATCH (n:Hack) RETURN count(n) AS n"}
            )
    print(json.dumps(out))


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2], sys.argv[3:]))
