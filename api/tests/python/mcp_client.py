"""Drives the OpenGraph MCP server with the official MCP Python client (PyPI `mcp`) and
prints one JSON object with what it saw, for api/tests/mcp.rs and api/tests/serve.rs to check.

usage: mcp_client.py OPENGRAPH_BINARY MAP [--allow-writes]   (stdio: starts `opengraph mcp`)
       mcp_client.py http://HOST:PORT/mcp [--token TOKEN]    (streamable HTTP, `opengraph serve`)
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


async def main(argv):
    out = {}
    if argv[0].startswith("http"):
        from mcp.client.streamable_http import streamable_http_client
        from mcp.shared._httpx_utils import create_mcp_http_client

        headers = {}
        if "--token" in argv:
            headers["Authorization"] = "Bearer " + argv[argv.index("--token") + 1]
        async with create_mcp_http_client(headers=headers) as http:
            async with streamable_http_client(argv[0], http_client=http) as (read, write):
                await session_calls(read, write, out)
    else:
        binary, db, extra = argv[0], argv[1], argv[2:]
        params = StdioServerParameters(command=binary, args=["mcp", "--db", db, *extra])
        async with stdio_client(params) as (read, write):
            await session_calls(read, write, out)
    print(json.dumps(out))


async def session_calls(read, write, out):
    if True:
        async with ClientSession(read, write) as session:
            init = await asyncio.wait_for(session.initialize(), 30)
            out["server"] = attr(init, "server_info", "serverInfo").name
            tools = await asyncio.wait_for(session.list_tools(), 30)
            out["tools"] = sorted(t.name for t in tools.tools)
            out["schemas"] = {t.name: attr(t, "input_schema", "inputSchema") for t in tools.tools}
            out["annotations"] = {}
            for t in tools.tools:
                a = t.annotations
                out["annotations"][t.name] = None if a is None else {
                    "title": a.title,
                    "read_only": attr(a, "read_only_hint", "readOnlyHint"),
                    "destructive": attr(a, "destructive_hint", "destructiveHint"),
                    "idempotent": attr(a, "idempotent_hint", "idempotentHint"),
                    "open_world": attr(a, "open_world_hint", "openWorldHint"),
                }
            resources = await asyncio.wait_for(session.list_resources(), 30)
            out["resources"] = sorted(str(r.uri) for r in resources.resources)
            out["resource_text"] = {}
            for uri in out["resources"]:
                r = await asyncio.wait_for(session.read_resource(uri), 30)
                out["resource_text"][uri] = "".join(getattr(c, "text", "") for c in r.contents)
            try:
                await asyncio.wait_for(session.read_resource("opengraph://nothing"), 30)
                out["missing_resource"] = "no error"
            except Exception as e:  # a JSON-RPC error names the resources there are
                out["missing_resource"] = str(e)
            prompts = await asyncio.wait_for(session.list_prompts(), 30)
            out["prompts"] = {
                p.name: [a.name for a in (p.arguments or [])] for p in prompts.prompts
            }
            for name in out["prompts"]:
                p = await asyncio.wait_for(
                    session.get_prompt(name, {"question": "How many benches are there?"}), 30
                )
                out.setdefault("prompt_text", {})[name] = "".join(
                    getattr(m.content, "text", "") for m in p.messages
                )

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


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1:]))
