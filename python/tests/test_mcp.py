"""`bw4t mcp` through the official MCP SDK's client: a scripted delivery over stdio and
over streamable HTTP, two MCP robots and a built-in one completing a `bw4t run` match
(their usage, invalid calls and result tokens against their transcripts), bad arguments
answered as tool errors (`isError`) naming the problem, the tools' enums, hints and output
schema, brief results, timeouts and a second call while one runs, the resources and the
prompt, the same run twice, a slow driver losing no ticks, the decision log, the
transcript against the replay, `--served` without its variables, a tournament team of
MCP-driven agents, and the MCP Inspector's CLI. Every result the SDK receives is checked
by the SDK against the tool's output schema.

The scripted player is mcp_player.py. The SDK needs Python 3.10 or newer: without it the
module is skipped. Every await is bounded, so a hang fails instead of blocking.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any, AsyncIterator, Awaitable, Dict, List, Optional, Tuple, TypeVar

import pytest
import jsonschema

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
        # The clock, in the data and in the words, in every result.
        tick, limit = call.result["tick"], call.result["max_ticks"]
        assert limit == 20000 and call.result["ticks_left"] == limit - tick, call.result
        assert f"Tick {tick} of {limit} ({limit - tick} left" in call.text, call.text


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
    def agent(name: str, invalid: int) -> str:
        transcript = tmp_path / f"{name}.transcript.jsonl"
        return (
            f"{shlex.quote(sys.executable)} {shlex.quote(str(PLAYER))} --bw4t {shlex.quote(bw4t_bin)} "
            f"--tokens-per-call 100 --invalid-calls {invalid} -- --transcript {shlex.quote(str(transcript))}"
        )

    out = subprocess.run(
        [bw4t_bin, "run", "--map", "fixed", "--seed", "1", "--robots", "3", "--agent", agent("Agent1", 2),
         "--agent", agent("Agent2", 0), "--team", "builtin", "--deadline-ms", "0", "--json", "--log-dir", str(tmp_path)],
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
        # Invalid calls and the tokens of the results, as its transcript has them: every
        # result answered before the match ended was reported (those after it cannot be).
        transcript = [json.loads(line) for line in (tmp_path / f"{name}.transcript.jsonl").read_text().splitlines()]
        assert len(transcript) == summary["tool_calls"]
        assert usage["invalid_calls"] == summary["invalid_calls"] == sum(t["is_error"] for t in transcript)
        assert usage["invalid_calls"] == (2 if name == "Agent1" else 0)
        counted = sum(t["result_tokens"] for t in transcript if t["outcome"] != "match_over")
        assert usage["result_tokens"] == counted > 0, (usage, counted)
        for line in transcript:
            assert line["result_tokens"] == -(-len(line["text"]) // 4), line
    assert "usage" not in robots["Bot1"], "a built-in robot reports nothing"
    assert sum(r["good_drops"] for r in robots.values()) == 6


HUGE = "Q" * 1_000_000
BAD_CALLS: List[Tuple[str, Dict[str, Any], List[str]]] = [
    ("go_to", {"place": "Nowhere"}, ["go_to", "'Nowhere' is not a place", "RoomA1"]),
    ("go_to", {}, ["go_to", "place"]),
    ("go_to_block", {"block": "x"}, ["go_to_block", '"x"']),
    ("go_to_block", {"block": HUGE}, ["go_to_block", "QQQ", "cut; 1000000 characters"]),
    ("go_to", {"place": "RoomA1", HUGE: 1}, ["go_to", "cut; 1000000 characters"]),
    ("say", {"kind": "shout"}, ["say", "'shout' is not a kind of message", "contains"]),
    ("say", {"kind": "have", "colour": "Red", "text": "hi"}, ["say", "not both"]),
    ("say", {"kind": "contains", "room": "RoomZ9", "colour": "Red"}, ["say", "'RoomZ9' is not a room", "RoomA1"]),
    ("say", {"kind": "have", "colour": "Purple"}, ["say", "'Purple' is not a colour", "Yellow"]),
    ("say", {"kind": "giving_up", "position": 0}, ["say", "position must be from 1"]),
    ("say", {"kind": "contains_many", "room": "RoomA1", "colour": "Red", "count": 5000}, ["say", "count"]),
    ("say", {"text": "x" * 281}, ["say", "281 characters", "the most is 280"]),
    ("wait", {"ticks": 0}, ["wait", "ticks"]),
]


def test_bad_arguments_are_tool_errors_naming_the_problem(bw4t_bin: str, tmp_path: Path) -> None:
    """Input errors are tool results with `isError` (the MCP spec's tool execution errors,
    which a host shows the model), naming the problem and quoting at most a short piece of
    what was given; an unknown tool stays a protocol error. None of them moves the match,
    and every one is in the transcript."""
    transcript = tmp_path / "transcript.jsonl"

    async def main() -> Tuple[list, Dict[str, Any], Dict[str, Any]]:
        async with stdio_session(own_match(bw4t_bin, "--transcript", str(transcript))) as session:
            tools = {t.name: t for t in (await bounded(session.list_tools())).tools}
            results = [await bounded(session.call_tool(tool, args)) for tool, args, _ in BAD_CALLS]
            with pytest.raises(MCPError) as unknown:
                await bounded(session.call_tool("fly", {}))
            assert unknown.value.code == -32602 and "'fly'" in unknown.value.message
            assert "look, go_to" in unknown.value.message
            with pytest.raises(MCPError) as caught:
                await bounded(session.read_resource("bw4t://nothing"))
            assert "bw4t://nothing" in caught.value.message and "bw4t://rules" in caught.value.message
            with pytest.raises(MCPError) as caught:
                await bounded(session.get_prompt("chat"))
            assert "'chat'" in caught.value.message and "'play'" in caught.value.message
            # None of them did anything: the robot is where it started, at tick 0.
            look = await bounded(session.call_tool("look", {}))
            assert look.structured_content["tick"] == 0
        return results, tools["go_to"].output_schema, look.structured_content

    results, schema, look = run(main())
    for (tool, args, words), res in zip(BAD_CALLS, results):
        assert res.is_error is True, (tool, res)
        text = "".join(c.text for c in res.content)
        for word in words:
            assert word in text, (tool, word, text[:500])
        assert len(text) < 2000, (tool, len(text))  # a megabyte given is not sent back
        data = res.structured_content
        jsonschema.validate(data, schema)
        assert data["outcome"] == "invalid" and data["tick"] == 0 and data["max_ticks"] == 20000, data
        assert data["error"].startswith(f"{tool}: ") and data["error"] in text
    lines = [json.loads(line) for line in transcript.read_text().splitlines()]
    assert [(line["tool"], line["is_error"], line["outcome"]) for line in lines] == [
        *[(tool, True, "invalid") for tool, _, _ in BAD_CALLS], ("look", False, "looked")
    ]
    assert lines[-1]["structured"] == look


def test_the_tools_carry_enums_hints_and_an_output_schema(bw4t_bin: str) -> None:
    """The input schemas name the map's places, the colours and the kinds; the hints say
    which tools change nothing; one output schema fits every result (the SDK checks each
    result against it)."""

    async def main() -> Tuple[Dict[str, Any], str, Any]:
        async with stdio_session(own_match(bw4t_bin)) as session:
            tools = {t.name: t for t in (await bounded(session.list_tools())).tools}
            text = (await bounded(session.read_resource("bw4t://map"))).contents[0].text
            said = await bounded(session.call_tool("say", {"kind": "giving_up", "position": 1}))
            return tools, text, said

    tools, map_text, said = run(main())
    places = re.findall(r"^- (\S+) \(", map_text, re.MULTILINE)
    place_enum = tools["go_to"].input_schema["properties"]["place"]["enum"]
    assert sorted(place_enum) == sorted(places) and "DropZone" in places
    say = tools["say"].input_schema["properties"]
    assert "Yellow" in say["colour"]["enum"] and "Purple" not in say["colour"]["enum"]
    assert {"contains", "have", "giving_up"} <= set(say["kind"]["enum"])
    assert set(say["room"]["enum"]) <= set(places) and "RoomA1" in say["room"]["enum"]
    assert say["position"]["minimum"] == 1 and "1 for the first colour" in say["position"]["description"]
    assert say["text"]["maxLength"] == 280
    hints = {name: tool.annotations for name, tool in tools.items()}
    assert hints["look"].read_only_hint is True and hints["look"].idempotent_hint is True
    assert all(hints[name].read_only_hint is False for name in TOOLS if name != "look")
    assert hints["put_down"].destructive_hint is True and hints["go_to"].destructive_hint is False
    for tool in tools.values():
        assert tool.output_schema is not None and tool.output_schema["type"] == "object", tool.name
    # Position 1 in the tool is the first position on the wire, and in the sentence.
    assert not said.is_error and said.structured_content["outcome"] == "done"
    jsonschema.validate(said.structured_content, tools["say"].output_schema)


def test_brief_results_carry_only_what_changed(bw4t_bin: str) -> None:
    async def main() -> List[Any]:
        async with stdio_session(own_match(bw4t_bin, "--brief")) as session:
            calls = [("look", {}), ("go_to", {"place": "RoomA3"}), ("say", {"kind": "have", "colour": "Yellow"}),
                     ("look", {})]
            return [await bounded(session.call_tool(tool, args)) for tool, args in calls]

    first, went, said, looked = run(main())
    def text(res: Any) -> str:
        return "".join(c.text for c in res.content)

    for res in (first, looked):
        assert res.structured_content["brief"] is False and "Goal:" in text(res)
        assert set(res.structured_content["state"]) >= {"sequence", "at", "holding", "players"}
    assert went.structured_content["brief"] is True and "Goal:" not in text(went)
    state = went.structured_content["state"]
    assert state["at"] == "RoomA3" and state["tick"] == went.structured_content["tick"]
    assert "sequence" not in state and "players" not in state, state  # unchanged since the look
    assert "I arrived at RoomA3." in text(went) and "Tick " in text(went)
    assert set(said.structured_content["state"]) <= {"tick"}, said.structured_content["state"]
    assert len(text(said)) < len(text(looked)) / 3, (text(said), text(looked))


def test_the_transcript_matches_the_calls_and_the_replay(bw4t_bin: str, tmp_path: Path) -> None:
    transcript, replay = tmp_path / "decisions.transcript.jsonl", tmp_path / "match.replay.jsonl"

    async def main() -> Play:
        argv = own_match(bw4t_bin, "--log", str(tmp_path / "decisions.jsonl"), "--replay", str(replay))
        async with stdio_session(argv) as session:
            return await play(session, deliveries=1)

    record = run(main())
    lines = [json.loads(line) for line in transcript.read_text().splitlines()]
    assert [line["tool"] for line in lines] == [c.tool for c in record.calls]
    for line, call in zip(lines, record.calls):
        assert line["text"] == call.text and line["structured"] == call.result and line["is_error"] is False
        assert (line["tick_start"], line["tick_end"]) == (call.result["started_tick"], call.result["tick"])
        assert line["result_tokens"] == -(-len(call.text) // 4)
    # Every action the transcript shows was applied at the tick it started, in the replay.
    acts: Dict[int, List[str]] = {}
    for raw in replay.read_text().splitlines():
        entry = json.loads(raw)
        if entry["type"] == "tick":
            for event in entry["events"]:
                if event.get("kind", event.get("type")) == "act" and event["robot"] == 0:
                    acts.setdefault(entry["tick"], []).append(event["action"])
    wire = {"go_to": "goTo", "go_to_block": "goToBlock", "pick_up": "pickUp", "put_down": "putDown"}
    actions = [(line["tick_start"], wire[line["tool"]]) for line in lines if line["tool"] in wire]
    assert actions and all(action in acts.get(tick, []) for tick, action in actions), (actions, acts)
    assert sum(len(v) for v in acts.values()) == len(actions), "the replay has no action the transcript lacks"


def test_served_without_its_variables_fails_naming_them(bw4t_bin: str) -> None:
    """What an MCP host that drops the environment gives `bw4t mcp --served`: an error naming
    the missing variables and how to pass them, not a match of its own."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("BW4T_")}
    out = subprocess.run([bw4t_bin, "mcp", "--served"], capture_output=True, text=True, timeout=30, env=env,
                         stdin=subprocess.DEVNULL)
    assert out.returncode != 0 and out.stdout == ""
    for word in ("--served", "BW4T_HOST, BW4T_PORT, BW4T_NAME, BW4T_TOKEN", '"env"', "--connect"):
        assert word in out.stderr, out.stderr
    env["BW4T_HOST"], env["BW4T_PORT"] = "127.0.0.1", "1"
    out = subprocess.run([bw4t_bin, "mcp", "--served"], capture_output=True, text=True, timeout=30, env=env,
                         stdin=subprocess.DEVNULL)
    assert out.returncode != 0 and "BW4T_NAME, BW4T_TOKEN not set" in out.stderr, out.stderr


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
        assert row["invalid_calls"] == 0 and row["result_tokens"] >= row["tool_calls"] - 1 > 0, row


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


def test_bw4t_eval_scores_an_mcp_driven_agent_with_its_usage(bw4t_bin: str, tmp_path: Path) -> None:
    """`bw4t eval` on the `pair` tier with the scripted MCP player as the agent: a
    leaderboard row whose usage sums what each `bw4t mcp` reported."""
    agent = f"{sys.executable} {PLAYER} --bw4t {bw4t_bin} --tokens-per-call 10"
    out = subprocess.run(
        [bw4t_bin, "eval", "pair", "--agent", agent, "--deadline-ms", "0", "--wall-budget-s", "300",
         "--name", "scripted-mcp", "--model", "none", "--harness", "mcp_player.py", "--out", str(tmp_path / "eval")],
        capture_output=True, text=True, timeout=600,
    )
    assert out.returncode == 0, out.stderr
    row = json.loads(out.stdout)
    assert (row["tier"], row["agent"]["name"], row["agent"]["harness"]) == ("pair", "scripted-mcp", "mcp_player.py")
    assert row["crashed_matches"] == 0 and row["failed_matches"] == 0, row
    assert row["completion"] > 0 and row["score"] > 0, row
    usage = row["usage"]
    assert usage["tool_calls"] > 0 and usage["prompt_tokens"] == 10 * usage["tool_calls"], usage
    assert usage["invalid_calls"] == 0 and usage["result_tokens"] > 0, usage
    agent_rows = [json.loads(line) for line in (tmp_path / "eval" / "agent" / "matches.jsonl").read_text().splitlines()]
    assert usage["tool_calls"] == sum(r["tool_calls"] for r in agent_rows)
