"""``python -m bw4t.bench``: agent-steps per second from Python, one JSON object per line.

The same work on every path: the default map, 3 learning robots, every robot acting every
step with a random action (among those its mask allows, where there is a mask), counted
as agent-steps (robots × steps):

- ``single``: one ``parallel_env`` stepped in a Python loop (dicts in, dicts out);
- ``vector``: ``vector_env`` of 64 and 256 matches (``copy=False``), stepped in Rust on
  every core without the interpreter; actions for all rows at once with NumPy;
- ``tcp``: the same match served by ``bw4t serve`` in lockstep, 3 players of the TCP
  client (``AsyncClient``) on loopback, one step per tick;

each at 1 tick per step (a step per simulated tick, as the simulation counts) and at the
environments' default 10. Then ``vector_memory``: resident memory per match of a vector.

``mcp`` (only when asked for: it needs the MCP SDK, Python 3.10 or newer) measures
``bw4t mcp`` through the SDK's client: ``mcp_round_trip``, the round trip of a ``look``
and of a ``wait(ticks=1)`` (which crosses one tick) over stdio and over streamable HTTP on
loopback (milliseconds, p50 and p99); and ``mcp_match``, ticks per second of a lockstep
match on the fixed map in which one robot goes back and forth between two places, driven
by a scripted MCP client that answers at once, and the same work done by the TCP client
(``AsyncClient``) on ``bw4t serve --mode lockstep``.
"""

from __future__ import annotations

import argparse
import asyncio
import importlib.util
import json
import logging
import re
import secrets
import subprocess
import sys
import time
from contextlib import asynccontextmanager
from typing import Any, AsyncIterator, Dict, List, Optional, Tuple

import numpy as np

from .env import parallel_env, vector_env

ROBOTS = 3


def emit(row: Dict) -> None:
    print(json.dumps(row), flush=True)


def random_allowed(noise: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """Per row, a uniformly random allowed action: allowed entries are in [1, 2), the others
    in [0, 1), so the largest is a random allowed one."""
    return np.argmax(noise + masks, axis=1)


def bench_single(ticks_per_step: int, steps: int, seed: int) -> Dict:
    env = parallel_env(robots=ROBOTS, ticks_per_step=ticks_per_step)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    n = env.spec_native.n_actions
    noise = rng.random((64, n), dtype=np.float32)
    names = env.possible_agents
    episodes = 0
    start = time.perf_counter()
    for step in range(steps):
        actions = {}
        for i, name in enumerate(names):
            mask = obs[name]["action_mask"]
            actions[name] = int(np.argmax(noise[(step * ROBOTS + i) % 64] + mask))
        obs, _, _, _, _ = env.step(actions)
        if not env.agents:
            episodes += 1
            obs, _ = env.reset()
    seconds = time.perf_counter() - start
    return {
        "case": "single",
        "path": "parallel_env in a Python loop",
        "envs": 1,
        "agents": ROBOTS,
        "ticks_per_step": ticks_per_step,
        "steps": steps,
        "agent_steps": steps * ROBOTS,
        "episodes_ended": episodes,
        "seconds": round(seconds, 3),
        "agent_steps_per_s": round(steps * ROBOTS / seconds),
    }


def bench_vector(matches: int, ticks_per_step: int, steps: int, seed: int, threads: Optional[int]) -> Dict:
    vec = vector_env(num_matches=matches, robots=ROBOTS, ticks_per_step=ticks_per_step, copy=False, threads=threads)
    obs, _ = vec.reset(seed=seed)
    rng = np.random.default_rng(seed)
    noise = [rng.random(vec.masks.shape, dtype=np.float32) for _ in range(8)]
    masks = obs["action_mask"]
    ended = 0
    start = time.perf_counter()
    for step in range(steps):
        actions = random_allowed(noise[step % 8], masks)
        _, _, terminated, truncated, _ = vec.step(actions)
        ended += int(np.count_nonzero(terminated | truncated)) // ROBOTS
    seconds = time.perf_counter() - start
    return {
        "case": "vector",
        "path": "vector_env, stepped in Rust without the GIL",
        "envs": matches,
        "agents": ROBOTS,
        "threads": vec.threads,
        "ticks_per_step": ticks_per_step,
        "steps": steps,
        "agent_steps": steps * matches * ROBOTS,
        "episodes_ended": ended,
        "seconds": round(seconds, 3),
        "agent_steps_per_s": round(steps * matches * ROBOTS / seconds),
    }


def bw4t_command(*args: str) -> List[str]:
    """The ``bw4t`` command of this package (the wheel's)."""
    return [sys.executable, "-m", "bw4t", *args]


def lockstep_server(*args: str) -> Tuple[subprocess.Popen, str, int]:
    """A ``bw4t serve --once --mode lockstep`` child on a free port, with ``args``; its
    process and the address it listens on. The caller kills it."""
    server = subprocess.Popen(
        bw4t_command("serve", "--once", "--mode", "lockstep", "--port", "0", *args),
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    assert server.stdout is not None
    first = server.stdout.readline().strip()
    if not first.startswith("listening on "):
        server.kill()
        raise RuntimeError(f"bw4t serve did not start: {first!r}")
    host, port = first[len("listening on "):].rsplit(":", 1)
    return server, host, int(port)


def bench_tcp(ticks: int, seed: int) -> Dict:
    """3 TCP-client players in lockstep on a `bw4t serve` child, one step per tick."""
    from . import AsyncClient

    server, host, port = lockstep_server("--robots", str(ROBOTS), "--seed", str(seed), "--max-ticks", str(ticks + 10))
    try:

        async def player(name: str, rng: np.random.Generator, counts: List[int]) -> None:
            client = await AsyncClient.connect(host, int(port), name, every_tick=True)
            places = client.beliefs.places
            async for update in client.updates():
                if update.tick >= ticks:
                    break
                counts[0] += 1
                # Mostly a new destination, sometimes nothing new (as the env's wait).
                if rng.random() < 0.8:
                    client.go_to(places[int(rng.integers(len(places)))])
            await client.close()

        async def main() -> float:
            counts = [0]
            start = time.perf_counter()
            await asyncio.gather(*(player(f"P{i}", np.random.default_rng(seed + i), counts) for i in range(ROBOTS)))
            seconds = time.perf_counter() - start
            main.steps = counts[0]  # type: ignore[attr-defined]
            return seconds

        seconds = asyncio.run(main())
        agent_steps = main.steps  # type: ignore[attr-defined]
    finally:
        server.kill()
        server.wait(timeout=30)
    return {
        "case": "tcp",
        "path": "bw4t serve --mode lockstep, 3 AsyncClient players on loopback",
        "envs": 1,
        "agents": ROBOTS,
        "ticks_per_step": 1,
        "steps": agent_steps // ROBOTS,
        "agent_steps": agent_steps,
        "seconds": round(seconds, 3),
        "agent_steps_per_s": round(agent_steps / seconds),
    }


MEMORY_SCRIPT = """
import os, sys
import numpy as np
from bw4t.env import vector_env

def resident_kb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") // 1024

matches, seed = int(sys.argv[1]), int(sys.argv[2])
before = resident_kb()
vec = vector_env(num_matches=matches, robots=3, copy=False)
vec.reset(seed=seed)
for _ in range(20):
    vec.step(np.zeros(vec.num_envs, dtype=np.uint32))
print(resident_kb() - before, vec.spec_native.obs_len, vec.spec_native.n_actions)
"""


def bench_memory(matches: int, seed: int) -> Dict:
    """Resident memory a fresh process gains by making and stepping a vector (the arrays
    included), per match."""
    out = subprocess.run(
        [sys.executable, "-c", MEMORY_SCRIPT, str(matches), str(seed)], capture_output=True, text=True, check=True
    )
    kb, obs_len, n_actions = (int(x) for x in out.stdout.split())
    return {
        "case": "vector_memory",
        "envs": matches,
        "agents": ROBOTS,
        "obs_len": obs_len,
        "n_actions": n_actions,
        "kb_per_match": round(kb / matches, 1),
    }


#: The two places the robot of ``mcp_match`` goes between, on the fixed map.
SHUTTLE = ("RoomA1", "DropZone")
#: Seconds any one await of the ``mcp`` case may take (a hang fails the bench).
MCP_BOUND = 120.0




async def _bounded(awaitable: Any) -> Any:
    return await asyncio.wait_for(awaitable, MCP_BOUND)


@asynccontextmanager
async def _mcp_session(transport: str, args: List[str]) -> AsyncIterator[Any]:
    """An initialized MCP session of ``bw4t mcp ARGS`` over ``transport``."""
    from mcp import ClientSession, StdioServerParameters
    from mcp.client.stdio import stdio_client
    from mcp.client.streamable_http import streamable_http_client

    command = bw4t_command("mcp", *args)
    if transport == "stdio":
        params = StdioServerParameters(command=command[0], args=command[1:])
        async with stdio_client(params, errlog=subprocess.DEVNULL) as (read, write):  # type: ignore[arg-type]
            async with ClientSession(read, write) as session:
                await _bounded(session.initialize())
                yield session
        return
    # Over HTTP the robot answers only the holder of its bearer token.
    token = secrets.token_hex(16)
    proc = await asyncio.create_subprocess_exec(
        *command, "--http", "127.0.0.1:0", "--http-token", token,
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    try:
        assert proc.stderr is not None
        url = None
        while url is None:
            line = (await _bounded(proc.stderr.readline())).decode()
            if not line:
                raise RuntimeError("bw4t mcp --http ended without printing its address")
            found = re.search(r"(http://\S+/mcp)", line)
            url = found.group(1) if found else None
        drain = asyncio.ensure_future(proc.stderr.read())
        try:  # the HTTP client the MCP SDK is built on: httpx2 from SDK 2.x, httpx before
            import httpx2 as httpx  # type: ignore[import-not-found]
        except ImportError:
            import httpx  # type: ignore[no-redef]
        headers = {"Authorization": f"Bearer {token}"}
        client = httpx.AsyncClient(headers=headers, timeout=httpx.Timeout(30.0, read=300.0))
        async with client, streamable_http_client(url, http_client=client) as (read, write):
            async with ClientSession(read, write) as session:
                await _bounded(session.initialize())
                yield session
        drain.cancel()
    finally:
        if proc.returncode is None:
            proc.kill()
        await _bounded(proc.wait())


def _ms_percentiles(seconds: List[float]) -> Tuple[float, float]:
    p50, p99 = np.percentile(np.array(seconds) * 1000.0, [50, 99])
    return round(float(p50), 3), round(float(p99), 3)


async def _round_trip(transport: str, calls: int, seed: int) -> Dict:
    """``calls`` looks, then ``calls`` waits of one tick, each timed alone."""
    args = ["--map", "fixed", "--seed", str(seed), "--max-ticks", "100000000"]
    async with _mcp_session(transport, args) as session:
        times: Dict[str, List[float]] = {"look": [], "wait": []}
        for tool, arguments in (("look", {}), ("wait", {"ticks": 1})):
            for i in range(calls + 10):
                start = time.perf_counter()
                await _bounded(session.call_tool(tool, arguments))
                if i >= 10:  # the first few warm the path up
                    times[tool].append(time.perf_counter() - start)
    look, wait = _ms_percentiles(times["look"]), _ms_percentiles(times["wait"])
    return {
        "case": "mcp_round_trip",
        "transport": "stdio" if transport == "stdio" else "streamable HTTP on loopback",
        "calls": calls,
        "look_p50_ms": look[0],
        "look_p99_ms": look[1],
        "wait_tick_p50_ms": wait[0],
        "wait_tick_p99_ms": wait[1],
    }


async def _mcp_shuttle(ticks: int, seed: int) -> Dict:
    """A scripted MCP client: go_to between the two places until ``ticks`` have passed."""
    args = ["--map", "fixed", "--seed", str(seed), "--max-ticks", str(2 * ticks + 10000)]
    async with _mcp_session("stdio", args) as session:
        state = (await _bounded(session.call_tool("look", {}))).structured_content["state"]
        first, calls, leg = state["tick"], 1, 0
        start = time.perf_counter()
        while state["tick"] - first < ticks:
            res = await _bounded(session.call_tool("go_to", {"place": SHUTTLE[leg % 2]}))
            state, calls, leg = res.structured_content["state"], calls + 1, leg + 1
        seconds = time.perf_counter() - start
    done = state["tick"] - first
    return {
        "case": "mcp_match",
        "client": "mcp",
        "path": "bw4t mcp over stdio (its own lockstep match), a scripted MCP client",
        "ticks": done,
        "seconds": round(seconds, 3),
        "ticks_per_s": round(done / seconds),
        "tool_calls": calls,
    }


def _tcp_shuttle(ticks: int, seed: int) -> Dict:
    """The same work with the TCP client on ``bw4t serve --mode lockstep``."""
    from . import AsyncClient

    server, host, port = lockstep_server(
        "--robots", "1", "--map", "fixed", "--seed", str(seed), "--deadline-ms", "0", "--max-ticks", str(2 * ticks + 10000)
    )
    try:

        async def shuttle() -> Tuple[int, int, float]:
            client = await _bounded(AsyncClient.connect(host, int(port), "P0"))
            tick, orders, leg = 0, 0, 0
            start = time.perf_counter()
            while tick < ticks:
                result = await _bounded(client.go_to(SHUTTLE[leg % 2]))
                tick, orders, leg = result.tick, orders + 1, leg + 1
            seconds = time.perf_counter() - start
            await client.close()
            return tick, orders, seconds

        done, orders, seconds = asyncio.run(shuttle())
    finally:
        server.kill()
        server.wait(timeout=30)
    return {
        "case": "mcp_match",
        "client": "tcp",
        "path": "bw4t serve --mode lockstep, one AsyncClient on loopback",
        "ticks": done,
        "seconds": round(seconds, 3),
        "ticks_per_s": round(done / seconds),
        "actions": orders,
    }


def bench_mcp(calls: int, ticks: int, seed: int) -> List[Dict]:
    """The ``mcp`` case's rows: round trips per transport, then the two clients' matches."""
    rows = [asyncio.run(_round_trip(transport, calls, seed)) for transport in ("stdio", "http")]
    rows.append(asyncio.run(_mcp_shuttle(ticks, seed)))
    rows.append(_tcp_shuttle(ticks, seed))
    return rows


def main(argv: Optional[List[str]] = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bw4t.bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20000, help="steps of the single env per setting")
    parser.add_argument("--vector-steps", type=int, default=400, help="steps of each vector per setting")
    parser.add_argument("--tcp-ticks", type=int, default=3000, help="ticks of the TCP client path")
    parser.add_argument("--mcp-calls", type=int, default=1000, help="timed calls per tool and transport (mcp)")
    parser.add_argument("--mcp-ticks", type=int, default=200000, help="ticks of each client's match (mcp)")
    parser.add_argument("--threads", type=int, default=None, help="threads of the vector (default: cores)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--cases",
        default="single,vector,tcp,memory",
        help="comma-separated: single, vector, tcp, memory, mcp (not run unless named; needs the mcp package)",
    )
    args = parser.parse_args(argv)
    cases = set(args.cases.split(","))
    unknown = cases - {"single", "vector", "tcp", "memory", "mcp"}
    if unknown:
        parser.error(f"unknown case(s): {', '.join(sorted(unknown))}")
    if "mcp" in cases:
        if importlib.util.find_spec("mcp") is None:
            parser.error("the mcp case needs the MCP SDK: pip install 'mcp>=2.3' (Python 3.10 or newer)")
        # The SDK warns when the server answers the session's closing DELETE with 202.
        logging.getLogger("mcp.client.streamable_http").setLevel(logging.ERROR)
    for ticks_per_step in (1, 10):
        if "single" in cases:
            emit(bench_single(ticks_per_step, args.steps // ticks_per_step, args.seed))
        if "vector" in cases:
            for matches in (64, 256):
                emit(bench_vector(matches, ticks_per_step, args.vector_steps, args.seed, args.threads))
    if "tcp" in cases:
        emit(bench_tcp(args.tcp_ticks, args.seed))
    if "memory" in cases:
        emit(bench_memory(256, args.seed))
    if "mcp" in cases:
        for row in bench_mcp(args.mcp_calls, args.mcp_ticks, args.seed):
            emit(row)


if __name__ == "__main__":
    main()
