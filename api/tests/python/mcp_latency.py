"""p50 latency of each agent tool through the MCP server (one session, calls repeated).

usage: mcp_latency.py OPENGRAPH_BINARY MAP [REPEATS]
Prints one JSON object: {tool: p50 milliseconds}. An opt-in measurement, not a test.
"""
import asyncio
import json
import statistics
import sys
import time

from mcp import ClientSession, StdioServerParameters
from mcp.client.stdio import stdio_client

CALLS = {
    "get_schema": {},
    "read_cypher": {"query": "MATCH (i:Instance) WHERE i.semantic_class = 'car' RETURN count(i) AS n"},
    "find_objects": {"text": "the bench near the bus stop", "k": 5},
    "locate": {"text": "I'm at a T-junction, there's a traffic light nearby"},
    "plan_route": {"from": "the bus stop by the crossroads", "to": "somewhere I can post a letter"},
    "describe_area": {},
    "get_instance": None,  # filled with an id from find_objects
}


async def main(binary, db, repeats):
    params = StdioServerParameters(command=binary, args=["mcp", "--db", db])
    out = {}
    async with stdio_client(params) as (read, write):
        async with ClientSession(read, write) as session:
            await session.initialize()
            r = await session.call_tool("find_objects", {"text": "a bench", "k": 1})
            first = json.loads("".join(c.text for c in r.content))["results"][0]["id"]
            CALLS["get_instance"] = {"id": first}
            for name, args in CALLS.items():
                times = []
                for _ in range(repeats):
                    t = time.perf_counter()
                    await session.call_tool(name, args)
                    times.append((time.perf_counter() - t) * 1e3)
                out[name] = round(statistics.median(times), 1)
    print(json.dumps(out))


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 10))
