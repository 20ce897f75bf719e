"""`bw4t mcp` through the official MCP SDK's client: a scripted delivery over stdio and
over streamable HTTP, two MCP robots and a built-in one completing a `bw4t run` match,
bad arguments refused as MCP errors naming the problem, timeouts and a second call while
one runs, the resources and the prompt, the same run twice, a slow driver losing no
ticks, the decision log, a tournament team of MCP-driven agents, and the MCP Inspector's CLI.

The scripted player is mcp_player.py. The SDK needs Python 3.10 or newer: without it the
module is skipped. Every await is bounded, so a hang fails instead of blocking.
"""

from __future__ import annotations

import asyncio
import json
import re
import shlex
import shutil
import subprocess
import sys
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any, AsyncIterator, Awaitable, Dict, List, Optional, Tuple, TypeVar

import pytest

pytest.importorskip("mcp", reason="the MCP SDK (mcp) is not installed; it needs Python 3.10 or newer")

from mcp.shared.exceptions import MCPError  # noqa: E402

from conftest import REPO  # noqa: E402
from mcp_player import Play, http_session, play, stdio_session  # noqa: E402

#: Seconds any one await of a test may take.
BOUND = 60.0
PLAYER = Path(__file__).resolve().with_name("mcp_player.py")
TOOLS = ["look", "go_to", "go_to_block", "pick_up", "put_down", "say", "wait"]
T = TypeVar("T")


def run(coro: Awaitable[T], bound: float = BOUND) -> T:
    """Runs `coro` to its end, failing after `bound` seconds."""
    return asyncio.run(asyncio.wait_for(coro, bound))  # type: ignore[arg-type]


async def bounded(coro: Awaitable[T], bound: float = BOUND) -> T:
    return await asyncio.wait_for(coro, bound)


def own_match(bw4t_bin: str, *args: str) -> List[str]:
    """`bw4t mcp` with a match of its own on the fixed map, seed 1, alone."""
    return [bw4t_bin, "mcp", "--map", "fixed", "--seed", "1", *args]


@asynccontextmanager
async def http_server(argv: List[str]) -> AsyncIterator[Tuple[str, str]]:
    """Starts `argv` (a `bw4t mcp --http 127.0.0.1:0 ...`), yields the URL and the bearer
    token it prints on standard error, and kills it at the end."""
    proc = await asyncio.create_subprocess_exec(
        *argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    assert proc.stderr is not None
    said: List[str] = []
    url: Optional[str] = None
    try:
        while True:
            line = (await bounded(proc.stderr.readline(), 30)).decode()
            if not line:
                pytest.fail(f"bw4t mcp --http ended without an address and a token; it said: {''.join(said)!r}")
            said.append(line)
            found = re.search(r"MCP over streamable HTTP at (http://\S+/mcp)", line)
            if found:
                url = found.group(1)
            token = re.search(r"bearer token (\S+)", line)
            if token and url:
                break
        # Keep reading what it says, so that it never blocks on a full pipe.
        drain = asyncio.ensure_future(proc.stderr.read())
        yield url, token.group(1)
        drain.cancel()
    finally:
        if proc.returncode is None:
            proc.kill()
        await bounded(proc.wait(), 30)


def check_delivery(record: Play) -> None:
    """The scripted player explored, fetched the first colour and delivered it."""
    first, last = record.calls[0].result["state"], record.calls[-1]
    assert first["sequence_index"] == 0 and first["next_colour"] == "Yellow"
    tools = [c.tool for c in record.calls]
    assert tools[0] == "look" and tools[1] == "go_to"
    assert tools[-4:] == ["go_to_block", "pick_up", "go_to", "put_down"]
    assert record.delivered == 1
    assert last.tool == "put_down" and last.result["outcome"] == "done"
    state = last.result["state"]
    assert state["sequence_index"] == 1 and state["next_colour"] == "Red" and state["holding"] is None
    assert state["at"] == "DropZone" and last.result["ended"] is False
    # The text says what changed: every line of `changes` is in it.
    assert last.result["changes"], "the delivery changed something"
    for line in last.result["changes"]:
        assert line in last.text
    assert "Delivered: the team is now at 1 of 6; next needed: Red." in last.result["changes"]
    picked = record.calls[-3]
    assert picked.result["state"]["holding"]["colour"] == "Yellow"
    assert any(line.startswith("I picked up block") and "(Yellow)" in line for line in picked.result["changes"])
    for call in record.calls:
        assert call.result["outcome"] in ("looked", "arrived", "done"), (call.tool, call.result)
        assert call.result["tick"] == call.result["state"]["tick"]


def test_a_scripted_client_delivers_a_block_over_stdio(bw4t_bin: str) -> None:
    async def main() -> Play:
        async with stdio_session(own_match(bw4t_bin)) as session:
            init = session.initialize_result
            assert init is not None and init.server_info.name == "bw4t"
            tools = await bounded(session.list_tools())
            assert [t.name for t in tools.tools] == TOOLS
            return await play(session, deliveries=1)

    check_delivery(run(main()))


def test_a_scripted_client_delivers_a_block_over_streamable_http(bw4t_bin: str) -> None:
    async def main() -> Play:
        async with http_server(own_match(bw4t_bin, "--http", "127.0.0.1:0")) as (url, token):
            assert url.startswith("http://127.0.0.1:")
            async with http_session(url, token) as session:
                return await play(session, deliveries=1)

    check_delivery(run(main()))


def test_two_mcp_robots_and_a_built_in_one_complete_a_match(bw4t_bin: str, tmp_path: Path) -> None:
    agent = f"{shlex.quote(sys.executable)} {shlex.quote(str(PLAYER))} --bw4t {shlex.quote(bw4t_bin)} --tokens-per-call 100"
    out = subprocess.run(
        [bw4t_bin, "run", "--map", "fixed", "--seed", "1", "--robots", "3", "--agent", agent, "--agent", agent,
         "--team", "builtin", "--deadline-ms", "0", "--json", "--log-dir", str(tmp_path)],
        capture_output=True, text=True, timeout=120,
    )
    logs = {p.name: p.read_text() for p in tmp_path.glob("*.log")}
    assert out.returncode == 0, (out.stderr, logs)
    result = json.loads(out.stdout)
    assert result["completed"] is True and result["end_reason"] == "completed" and result["sequence_index"] == 6
    robots = {r["name"]: r for r in result["per_robot"]}
    assert sorted(robots) == ["Agent1", "Agent2", "Bot1"]
    assert [a["status"] for a in result["agents"]] == ["ok", "ok", "ok"]
    for name in ("Agent1", "Agent2"):
        robot = robots[name]
        assert robot["connected"] and robot["wrong_drops"] == 0
        assert robot["good_drops"] >= 1 or robot["rooms_entered"] > 0, robot
        # The player's own summary: it played until the tool results said the match was over.
        summary = json.loads(logs[f"{name}.log"].strip().splitlines()[-1])
        assert summary["ended"] is True and summary["delivered"] == robot["good_drops"]
        # What `bw4t mcp` reported: every call the match saw (the player's last call may
        # come after the end, answered `match_over` at once), with the tokens of its `_meta`.
        usage = robot["usage"]
        reported = usage["tool_calls"]
        assert summary["tool_calls"] - 1 <= reported <= summary["tool_calls"], (usage, summary)
        assert (usage["prompt_tokens"], usage["completion_tokens"]) == (100 * reported, reported)
        assert 0 <= usage["think_ms_max"] <= usage["think_ms"]
    assert "usage" not in robots["Bot1"], "a built-in robot reports nothing"
    assert sum(r["good_drops"] for r in robots.values()) == 6


BAD_CALLS: List[Tuple[str, Dict[str, Any], List[str]]] = [
    ("go_to", {"place": "Nowhere"}, ["go_to", "'Nowhere' is not a place", "RoomA1"]),
    ("go_to", {}, ["go_to", "place"]),
    ("go_to_block", {"block": "x"}, ["go_to_block", '"x"']),
    ("say", {"kind": "shout"}, ["say", "'shout'"]),
    ("say", {"kind": "have", "colour": "Red", "text": "hi"}, ["say", "not both"]),
    ("wait", {"ticks": 0}, ["wait", "ticks"]),
    ("fly", {}, ["'fly'", "look, go_to"]),
]


def test_bad_arguments_are_mcp_errors_naming_the_problem(bw4t_bin: str) -> None:
    async def main() -> List[Tuple[str, MCPError]]:
        errors = []
        async with stdio_session(own_match(bw4t_bin)) as session:
            for tool, args, _ in BAD_CALLS:
                with pytest.raises(MCPError) as caught:
                    await bounded(session.call_tool(tool, args))
                errors.append((tool, caught.value))
            with pytest.raises(MCPError) as caught:
                await bounded(session.read_resource("bw4t://nothing"))
            errors.append(("resource", caught.value))
            with pytest.raises(MCPError) as caught:
                await bounded(session.get_prompt("chat"))
            errors.append(("prompt", caught.value))
            # None of them did anything: the robot is where it started, at tick 0.
            look = await bounded(session.call_tool("look", {}))
            assert look.structured_content["tick"] == 0
        return errors

    errors = run(main())
    for (tool, args, words), (_, error) in zip(BAD_CALLS, errors):
        assert error.code == -32602, (tool, args, error.code, error.message)  # invalid params
        for word in words:
            assert word in error.message, (tool, args, error.message)
    resource, prompt = errors[-2][1], errors[-1][1]
    assert "bw4t://nothing" in resource.message and "bw4t://rules" in resource.message
    assert "'chat'" in prompt.message and "'play'" in prompt.message


@pytest.mark.parametrize("transport", ["stdio", "http"])
def test_wait_times_out_and_a_second_call_while_one_runs_is_refused(bw4t_bin: str, transport: str) -> None:
    # A call with no end of its own lasts its timeout in simulated time (lockstep): an
    # hour's timeout is 72000 ticks, long enough to be seen running.
    argv = own_match(bw4t_bin, "--max-ticks", "100000000", "--tool-timeout-s", "3600")

    async def scenario(session: Any) -> None:
        # Alone, nothing changes for the robot: the wait ends by its time, as an outcome.
        # In lockstep its seconds are simulated: 0.3 s at 20 ticks a second are 6 ticks.
        res = await bounded(session.call_tool("wait", {"seconds": 0.3}))
        assert not res.is_error and res.structured_content["outcome"] == "timeout"
        assert res.structured_content["ticks"] == 6
        assert res.structured_content["ended"] is False and res.structured_content["changes"] == []
        # A wait runs; the match's tick moves only while a call runs (lockstep), so a
        # later tick in `look` shows it has started. Then go_to is refused.
        start = res.structured_content["tick"]
        waiting = asyncio.ensure_future(session.call_tool("wait", {}))
        while (await bounded(session.call_tool("look", {}))).structured_content["tick"] == start:
            assert not waiting.done(), "the wait ended before the tick moved"
        with pytest.raises(MCPError) as caught:
            await bounded(session.call_tool("go_to", {"place": "RoomA1"}))
        assert "another action is still in progress (wait)" in caught.value.message
        assert caught.value.message.startswith("go_to:")
        res = await bounded(waiting)
        assert res.structured_content["outcome"] == "timeout" and res.structured_content["ticks"] == 72000
        # And then the robot takes orders again.
        res = await bounded(session.call_tool("go_to", {"place": "RoomA1"}))
        assert res.structured_content["outcome"] == "arrived"

    async def main() -> None:
        if transport == "stdio":
            async with stdio_session(argv) as session:
                await scenario(session)
        else:
            async with http_server([*argv, "--http", "127.0.0.1:0"]) as (url, token):
                async with http_session(url, token) as session:
                    await scenario(session)

    run(main())


def test_http_needs_the_bearer_token(bw4t_bin: str) -> None:
    """Over HTTP the robot is driven by whoever holds the token `bw4t mcp` printed: a
    client without it, or with another, gets nowhere. (Over stdio only the parent process
    can reach the server, so it needs none.)"""

    async def main() -> None:
        async with http_server(own_match(bw4t_bin, "--http", "127.0.0.1:0")) as (url, token):
            for wrong in [None, "not-the-token"]:
                with pytest.raises(BaseException) as caught:
                    async with http_session(url, wrong):
                        pass
                assert "401" in repr(caught.value) or "nauthorized" in repr(caught.value), caught.value
            async with http_session(url, token) as session:
                res = await bounded(session.call_tool("look", {}))
                assert res.structured_content["tick"] == 0, "nobody moved the robot"

    run(main())


def test_resources_and_the_play_prompt(bw4t_bin: str) -> None:
    async def main() -> Dict[str, Any]:
        async with stdio_session(own_match(bw4t_bin)) as session:
            listed = await bounded(session.list_resources())
            texts = {}
            for resource in listed.resources:
                read = await bounded(session.read_resource(resource.uri))
                texts[str(resource.uri)] = (read.contents[0].mime_type, read.contents[0].text)
            prompts = await bounded(session.list_prompts())
            prompt = await bounded(session.get_prompt("play"))
            return {"texts": texts, "prompts": [p.name for p in prompts.prompts], "prompt": prompt}

    got = run(main())
    texts = got["texts"]
    assert sorted(texts) == ["bw4t://goal", "bw4t://map", "bw4t://map.svg", "bw4t://rules"]
    mime, rules = texts["bw4t://rules"]
    assert mime == "text/markdown"
    assert "## Messages of the language" in rules and "| kind | arguments | sentence |" in rules
    for kind in ("going_to", "contains", "who_has"):
        assert f"| `{kind}` |" in rules, kind
    mime, map_text = texts["bw4t://map"]
    assert mime == "text/plain" and "RoomA1" in map_text and "DropZone" in map_text
    mime, svg = texts["bw4t://map.svg"]
    assert mime == "image/svg+xml" and svg.startswith("<svg") and svg.rstrip().endswith("</svg>")
    _, goal = texts["bw4t://goal"]
    assert "Yellow, Red, Blue, Green, White, Orange" in goal and "Yellow" in goal.split("next")[-1]
    assert got["prompts"] == ["play"]
    message = got["prompt"].messages[0]
    assert message.role == "user"
    for word in ["go_to", "put_down", "DropZone", "bw4t://rules", "Yellow, Red, Blue, Green, White, Orange"]:
        assert word in message.content.text, word


def test_the_same_scripted_run_twice_gives_the_same_match(bw4t_bin: str) -> None:
    async def once() -> List[Tuple[str, str, str, int, List[str]]]:
        async with stdio_session(own_match(bw4t_bin)) as session:
            record = await play(session)
        assert record.ended and record.delivered == 6
        return [
            (c.tool, json.dumps(c.args), c.result["outcome"], c.result["tick"], c.result["changes"])
            for c in record.calls
        ]

    first, second = run(once()), run(once())
    assert first == second
    assert first[-1][2] == "match_over" and first[-1][3] > 0


def inspector() -> Tuple[str, Path]:
    """npx and the folder whose node_modules hold the Inspector (tests/browser's)."""
    npx = shutil.which("npx")
    folder = REPO / "tests" / "browser"
    if npx is None:
        pytest.skip("npx (Node.js) is not installed")
    if not (folder / "node_modules" / "@modelcontextprotocol" / "inspector").is_dir():
        pytest.skip(f"the MCP Inspector is not installed: (cd {folder} && npm ci)")
    return npx, folder


def test_the_mcp_inspector_cli_lists_the_tools(bw4t_bin: str) -> None:
    npx, folder = inspector()
    out = subprocess.run(
        [npx, "--no-install", "@modelcontextprotocol/inspector", "--cli", bw4t_bin, "mcp", "--method", "tools/list"],
        cwd=folder, capture_output=True, text=True, timeout=120,
    )
    assert out.returncode == 0, out.stderr
    listed = json.loads(out.stdout)
    assert [t["name"] for t in listed["tools"]] == TOOLS
    go_to = next(t for t in listed["tools"] if t["name"] == "go_to")
    assert go_to["inputSchema"]["required"] == ["place"]


class Thinking:
    """A session whose every tool call comes after a pause of 0 to 40 ms, as a model's
    would after reading the last result (seeded, so both runs pause alike)."""

    def __init__(self, session: Any, seed: int) -> None:
        self.session = session
        self.pauses = __import__("random").Random(seed)

    async def call_tool(self, *args: Any, **kwargs: Any) -> Any:
        await asyncio.sleep(self.pauses.uniform(0.0, 0.04))
        return await self.session.call_tool(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.session, name)


def test_a_driver_that_thinks_between_calls_loses_no_ticks(bw4t_bin: str) -> None:
    """Lockstep holds the tick while the driver thinks: beside a built-in teammate, which
    would otherwise play on, a slow driver's match is the same, tick for tick."""

    async def once(slow: bool) -> List[Tuple[str, str, int, List[str]]]:
        async with stdio_session(own_match(bw4t_bin, "--teammates", "coop")) as session:
            record = await play(Thinking(session, 7) if slow else session, deliveries=1)
        return [(c.tool, json.dumps(c.args), c.result["tick"], c.result["changes"]) for c in record.calls]

    quick, slow = run(once(False)), run(once(True), 120)
    assert quick == slow


def test_the_decision_log_has_a_line_per_tool_call(bw4t_bin: str, tmp_path: Path) -> None:
    log = tmp_path / "decisions.jsonl"

    async def main() -> Play:
        async with stdio_session(own_match(bw4t_bin, "--log", str(log))) as session:
            return await play(session, deliveries=1)

    record = run(main())
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [line["tool"] for line in lines] == [c.tool for c in record.calls]
    for line, call in zip(lines, record.calls):
        assert line["think_ms"] >= 0 and line["run_ms"] >= 0
        if call.tool != "look":
            assert (line["outcome"], line["args"]) == (call.result["outcome"], call.args)
            assert line["tick"] + line["ticks"] == call.result["tick"]


def test_a_tournament_team_of_mcp_driven_agents_records_their_usage(bw4t_bin: str, tmp_path: Path) -> None:
    agent = f"{sys.executable} {PLAYER} --bw4t {bw4t_bin} --tokens-per-call 10"
    config = tmp_path / "tournament.toml"
    config.write_text(
        'maps = ["fixed"]\nseeds = [1, 2]\ndeadline_ms = 0\nwall_budget_s = 300\n\n'
        f'[[team]]\nname = "mcp"\nagents = [{json.dumps(agent)}, "builtin"]\n'
    )
    out = subprocess.run(
        [bw4t_bin, "tournament", str(config), "--out", str(tmp_path / "out"), "--replays", "none"],
        capture_output=True, text=True, timeout=240,
    )
    assert out.returncode == 0, out.stderr
    rows = [json.loads(line) for line in (tmp_path / "out" / "matches.jsonl").read_text().splitlines()]
    assert len(rows) == 2
    for row in rows:
        assert row["completed"] is True and row["out_of_time"] is False, row
        assert row["tool_calls"] > 0 and row["prompt_tokens"] == 10 * row["tool_calls"], row
        assert row["completion_tokens"] == row["tool_calls"] and row["think_ms"] >= 0, row


def test_a_robot_joins_a_served_match_by_address_and_name(bw4t_bin: str) -> None:
    """`--connect HOST:PORT --match NAME --name N` joins a `bw4t serve` match like any
    player, and the map resources come from the match's map name."""

    async def main() -> Play:
        serve = await asyncio.create_subprocess_exec(
            bw4t_bin, "serve", "--once", "--port", "0", "--map", "fixed", "--seed", "1", "--mode", "lockstep",
            "--deadline-ms", "0", "--max-ticks", "5000",
            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        )
        assert serve.stdout is not None
        try:
            address = None
            while address is None:
                line = (await bounded(serve.stdout.readline(), 30)).decode()
                assert line, "bw4t serve ended without an address"
                found = re.search(r"listening on (\S+:\d+)", line)
                address = found and found.group(1)
            drain = asyncio.ensure_future(serve.stdout.read())
            command = [bw4t_bin, "mcp", "--connect", address, "--match", "default", "--name", "Ann"]
            async with stdio_session(command) as session:
                record = await play(session, deliveries=1)
                rules = await bounded(session.read_resource("bw4t://map"))
                assert "Map 'fixed'" in rules.contents[0].text
            drain.cancel()
            return record
        finally:
            if serve.returncode is None:
                serve.kill()
            await bounded(serve.wait(), 30)

    record = run(main())
    assert record.delivered == 1 and record.calls[0].result["state"]["robot"] == 0
