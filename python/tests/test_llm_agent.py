"""The LLM agent example (examples/llm_agent.py): reading model replies, the tool definitions,
and the whole loop against a scripted chat endpoint and a fake MCP session.

No model and no network: the chat endpoint is an `http.server` on 127.0.0.1 that replays
recorded-looking completions (fixtures/llm_replies/), and the MCP side is a fake session,
or, where the MCP SDK is installed, a stand-in server spoken to over stdio.
"""

from __future__ import annotations

import asyncio
import importlib.util
import io
import json
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple

import pytest

PYTHON_DIR = Path(__file__).resolve().parents[1]
FIXTURES = Path(__file__).resolve().parent / "fixtures"
REPLIES = FIXTURES / "llm_replies"


def load_agent():
    """The example by path: it lives outside the package."""
    spec = importlib.util.spec_from_file_location("llm_agent", PYTHON_DIR / "examples" / "llm_agent.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["llm_agent"] = module  # dataclasses look their module up while the file runs
    spec.loader.exec_module(module)
    return module


agent = load_agent()


def reply(name: str) -> Dict[str, Any]:
    return json.loads((REPLIES / f"{name}.json").read_text())


def tools_list() -> Dict[str, Any]:
    """The recorded `tools/list` result of `bw4t mcp`."""
    return json.loads((FIXTURES / "mcp_tools_list.json").read_text())["result"]


def calls(parsed) -> List[Tuple[str, str, Dict[str, Any], Optional[str]]]:
    return [(c.id, c.name, c.arguments, c.error) for c in parsed.tool_calls]


# ---------------------------------------------------------------------------------------
# Reading replies


@pytest.mark.parametrize(
    "name, text, expected_calls, finish_reason, native",
    [
        ("openai_tool_call", "", [("call_Qm3YdL0pV8sT2wJk", "go_to", {"place": "RoomC1"}, None)], "tool_calls", True),
        (
            "parallel_tool_calls",
            "",
            [
                ("call_a1", "go_to_block", {"block": 11}, None),
                ("call_a2", "pick_up", {}, None),
                ("call_a3", "say", {"kind": "will_get", "colour": "Yellow", "to": "all"}, None),
            ],
            "tool_calls",
            True,
        ),
        (
            "content_json",
            '{"tool": "go_to", "arguments": {"place": "RoomC1"}}',
            [("text_0", "go_to", {"place": "RoomC1"}, None)],
            "stop",
            False,
        ),
        (
            "fenced_json",
            'I should first find out where I am.\n\n```json\n{\n  "tool": "look",\n  "arguments": {}\n}\n```\n',
            [("text_0", "look", {}, None)],
            "stop",
            False,
        ),
        (
            "text_tool_call_tag",
            '<tool_call>\n{"name": "say", "parameters": {"kind": "going_to", "room": "RoomC1"}}\n</tool_call>',
            [("text_0", "say", {"kind": "going_to", "room": "RoomC1"}, None)],
            "stop",
            False,
        ),
        (
            "malformed_arguments",
            "",
            [
                (
                    "call_x9",
                    "go_to",
                    {},
                    "the arguments are not valid JSON (Expecting ',' delimiter at character 18): {\"place\": \"RoomC1\"",
                )
            ],
            "tool_calls",
            True,
        ),
        ("empty_reply", "", [], "stop", False),
        (
            "length_cutoff",
            "The sequence needs Red first. RoomA1 and RoomB2 are unexplored, and RoomC1 was reported "
            "to contain Yellow, so the best plan is to",
            [],
            "length",
            False,
        ),
    ],
)
def test_parse_reply(name, text, expected_calls, finish_reason, native):
    parsed = agent.parse_reply(reply(name))
    assert parsed.text == text
    assert calls(parsed) == expected_calls
    assert parsed.finish_reason == finish_reason
    assert parsed.native is native


@pytest.mark.parametrize(
    "arguments, expected",
    [
        ('{"block": 3}', ({"block": 3}, None)),
        ({"block": 3}, ({"block": 3}, None)),  # some servers send an object, not a string
        (None, ({}, None)),
        ("", ({}, None)),
        ("null", ({}, None)),
        ("[1, 2]", ({}, "the arguments must be a JSON object, not [1, 2]")),
        ("{'block': 3}", ({}, "the arguments are not valid JSON (Expecting property name enclosed in double quotes at character 1): {'block': 3}")),
    ],
)
def test_read_arguments(arguments, expected):
    assert agent.read_arguments(arguments) == expected


@pytest.mark.parametrize(
    "text, expected",
    [
        ("I will go.", []),
        ('{"room": "RoomC1"}', []),  # JSON, but no tool named
        ('Plan: {"tool": "put_down"}', [("put_down", {})]),
        ('{"function": {"name": "go_to", "arguments": "{\\"place\\": \\"DropZone\\"}"}}', [("go_to", {"place": "DropZone"})]),
        ('[{"tool": "look"}, {"tool": "wait", "args": {"ticks": 50}}]', [("look", {}), ("wait", {"ticks": 50})]),
        ('```\n{"tool_calls": [{"name": "pick_up", "arguments": {"block": 4}}]}\n```', [("pick_up", {"block": 4})]),
        # A broken fence falls back to scanning, which finds the object after it.
        ('```json\n{"tool": \n```\nthen {"tool": "look", "arguments": {}}', [("look", {})]),
    ],
)
def test_calls_in_text(text, expected):
    assert [(c.name, c.arguments) for c in agent.calls_in_text(text)] == expected


def test_parse_reply_without_choices_is_empty():
    assert agent.parse_reply({"error": {"message": "overloaded"}}) == agent.Reply("", [], None, native=False)


def test_content_parts_are_joined():
    response = {"choices": [{"message": {"content": [{"type": "text", "text": "a"}, {"type": "text", "text": "b"}]}}]}
    assert agent.parse_reply(response).text == "ab"


# ---------------------------------------------------------------------------------------
# Tool definitions


def test_openai_tools_from_the_recorded_tools_list():
    defs = agent.openai_tools(tools_list()["tools"])
    assert [d["function"]["name"] for d in defs] == ["look", "go_to", "go_to_block", "pick_up", "put_down", "say", "wait"]
    assert all(d["type"] == "function" for d in defs)
    by_name = {d["function"]["name"]: d["function"] for d in defs}
    # No arguments: `properties` is added, which OpenAI requires.
    assert by_name["look"]["parameters"] == {"type": "object", "properties": {}}
    assert by_name["look"]["description"].startswith("The robot's current state")
    # `$schema` is dropped; the rest is passed on as it is.
    assert by_name["go_to"]["parameters"] == {
        "title": "GoToArgs",
        "type": "object",
        "properties": {"place": {"description": "The place's name, e.g. RoomC1 or DropZone.", "type": "string"}},
        "required": ["place"],
    }
    assert sorted(by_name["say"]["parameters"]["properties"]) == sorted(
        ["kind", "room", "colour", "player", "count", "position", "text", "to"]
    )
    assert by_name["wait"]["parameters"]["properties"]["seconds"]["type"] == ["number", "null"]
    assert "required" not in by_name["pick_up"]["parameters"]


def test_tools_in_prompt_lists_each_tool_with_its_arguments():
    text = agent.tools_in_prompt(tools_list()["tools"])
    lines = text.splitlines()
    assert '{"tool": "NAME", "arguments": {...}}' in lines
    assert "- go_to(place: string): Travel to a place (a room, a hall or DropZone). Returns when the robot arrives, collides or is stopped." in lines
    assert any(line.startswith("- wait(ticks?: integer, seconds?: number): ") for line in lines)
    assert any(line.startswith("- look(): ") for line in lines)


def test_result_text_and_outcome():
    result = {
        "content": [{"type": "text", "text": "Arrived at RoomC1 after 110 ticks. I now see block 11 (Yellow)."}],
        "structuredContent": {"outcome": "arrived", "tick": 410, "changes": ["I now see block 11 (Yellow)."]},
    }
    assert agent.result_text(result) == "Arrived at RoomC1 after 110 ticks. I now see block 11 (Yellow)."
    assert agent.result_outcome(result) == ("arrived", 410, False)
    over = {"content": [], "structuredContent": {"outcome": "match_over", "tick": 900, "changes": [], "ended": True}}
    assert agent.result_text(over) == '{"outcome": "match_over", "tick": 900, "changes": [], "ended": true}'
    assert agent.result_outcome(over) == ("match_over", 900, True)
    error = {"content": [{"type": "text", "text": "unknown place"}], "isError": True}
    assert agent.result_text(error) == "Error: unknown place"
    assert agent.result_outcome(error) == ("error", None, False)


# ---------------------------------------------------------------------------------------
# The loop


class ChatScript:
    """A chat endpoint on 127.0.0.1 that answers each request with the next scripted
    (status, body) and keeps the requests it got."""

    def __init__(self, script: List[Tuple[int, Dict[str, Any]]]) -> None:
        self.script = list(script)
        self.requests: List[Dict[str, Any]] = []
        owner = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                length = int(self.headers["Content-Length"])
                owner.requests.append({"path": self.path, "headers": dict(self.headers), "body": json.loads(self.rfile.read(length))})
                status, body = owner.script.pop(0) if owner.script else (500, {"error": {"message": "script exhausted"}})
                data = json.dumps(body).encode()
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

            def log_message(self, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def endpoint(self, **kwargs: Any):
        port = self.server.server_address[1]
        return agent.ChatEndpoint(base_url=f"http://127.0.0.1:{port}/v1", model="test-model", retries=0, timeout=10, **kwargs)

    def bodies(self) -> List[Dict[str, Any]]:
        return [request["body"] for request in self.requests]


@pytest.fixture
def chat_script() -> Iterator[Any]:
    made: List[ChatScript] = []

    def make(script: List[Tuple[int, Dict[str, Any]]]) -> ChatScript:
        chat = ChatScript(script)
        chat.thread.start()
        made.append(chat)
        return chat

    yield make
    for chat in made:
        chat.server.shutdown()
        chat.server.server_close()


def tool_result(text: str, outcome: str, tick: int, ended: bool = False) -> Dict[str, Any]:
    structured: Dict[str, Any] = {"outcome": outcome, "tick": tick, "changes": [text]}
    if ended:
        structured["ended"] = True
    return {"content": [{"type": "text", "text": text}], "structuredContent": structured, "isError": False}


class FakeSession:
    """Stands in for `mcp.ClientSession`: canned results, per tool in call order."""

    def __init__(self, results: Dict[str, List[Dict[str, Any]]]) -> None:
        self.results = {name: list(queue) for name, queue in results.items()}
        self.calls: List[Tuple[str, Dict[str, Any], Dict[str, Any]]] = []

    async def list_tools(self) -> Dict[str, Any]:
        return tools_list()

    async def get_prompt(self, name: str, arguments: Optional[Dict[str, str]] = None) -> Dict[str, Any]:
        assert name == "play"
        return {
            "messages": [
                {"role": "user", "content": {"type": "text", "text": "You are a robot in BW4T."}},
                {"role": "user", "content": {"type": "text", "text": "Deliver the blocks in order."}},
            ]
        }

    async def call_tool(self, name: str, arguments: Optional[Dict[str, Any]] = None, *, meta: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
        self.calls.append((name, arguments, meta))
        return self.results[name].pop(0)


def completion(message: Dict[str, Any], finish_reason: str, prompt_tokens: int, completion_tokens: int) -> Tuple[int, Dict[str, Any]]:
    return 200, {
        "choices": [{"index": 0, "message": {"role": "assistant", **message}, "finish_reason": finish_reason}],
        "usage": {"prompt_tokens": prompt_tokens, "completion_tokens": completion_tokens},
    }


def native(*calls: Tuple[str, str, str]) -> Dict[str, Any]:
    return {
        "content": None,
        "tool_calls": [{"id": i, "type": "function", "function": {"name": n, "arguments": a}} for i, n, a in calls],
    }


def usage(prompt: int, completion_: int) -> Dict[str, Any]:
    return {"bw4t/usage": {"prompt_tokens": prompt, "completion_tokens": completion_}}


def test_loop_plays_until_the_match_is_over(chat_script):
    chat = chat_script(
        [
            completion(native(("c1", "look", "{}")), "tool_calls", 100, 10),
            completion(native(("c2", "go_to", '{"place": "RoomC1"')), "tool_calls", 200, 10),
            completion(native(("c3", "fly", '{"to": "RoomC1"}')), "tool_calls", 300, 10),
            completion({"content": '{"tool": "go_to", "arguments": {"place": "RoomC1"}}'}, "stop", 400, 10),
            completion({"content": ""}, "stop", 500, 0),
            completion(native(("c6", "go_to_block", '{"block": 11}'), ("c7", "pick_up", "{}")), "tool_calls", 600, 20),
            completion({"content": "Still thinking about the"}, "length", 700, 64),
            completion(native(("c8", "go_to", '{"place": "DropZone"}')), "tool_calls", 800, 10),
            completion(native(("c9", "put_down", "{}"), ("c10", "look", "{}")), "tool_calls", 900, 20),
        ]
    )
    session = FakeSession(
        {
            "look": [tool_result("I am in RoomA1. I hold nothing.", "done", 1)],
            "go_to": [
                tool_result("Arrived at RoomC1 after 110 ticks. I now see block 11 (Yellow).", "arrived", 120),
                tool_result("Arrived at DropZone after 90 ticks.", "arrived", 260),
            ],
            "go_to_block": [tool_result("At block 11.", "arrived", 140)],
            "pick_up": [tool_result("I hold block 11 (Yellow).", "done", 150)],
            "put_down": [tool_result("Delivered block 11 (Yellow). The match is over.", "match_over", 270, ended=True)],
        }
    )
    log = io.StringIO()
    progress = io.StringIO()
    options = agent.Options(max_turns=20, keep_turns=3, log=log, progress=progress)
    summary = asyncio.run(agent.play(session, chat.endpoint(temperature=0.2), options))

    # The calls the server got, each with the token counts so far (after that turn's reply).
    assert session.calls == [
        ("look", {}, usage(100, 10)),
        ("go_to", {"place": "RoomC1"}, usage(1000, 40)),
        ("go_to_block", {"block": 11}, usage(2100, 60)),
        ("pick_up", {}, usage(2100, 60)),
        ("go_to", {"place": "DropZone"}, usage(3600, 134)),
        ("put_down", {}, usage(4500, 154)),
    ]
    assert summary.as_dict() == {
        "summary": True,
        "outcome": "match_over",
        "turns": 9,
        "tool_calls": 6,
        "tick": 270,
        "prompt_tokens": 4500,
        "completion_tokens": 154,
        "wall_seconds": summary.as_dict()["wall_seconds"],
    }

    bodies = chat.bodies()
    assert len(bodies) == 9
    assert all(r["path"] == "/v1/chat/completions" for r in chat.requests)
    assert "Authorization" not in chat.requests[0]["headers"]
    first = bodies[0]
    assert first["model"] == "test-model" and first["temperature"] == 0.2
    assert [t["function"]["name"] for t in first["tools"]] == ["look", "go_to", "go_to_block", "pick_up", "put_down", "say", "wait"]
    assert first["messages"] == [
        {"role": "system", "content": "You are a robot in BW4T.\n\nDeliver the blocks in order."},
        {"role": "user", "content": agent.START_MESSAGE},
    ]
    # Malformed arguments and an unknown tool are answered to the model, not run.
    assert bodies[2]["messages"][-2:] == [
        {
            "role": "assistant",
            "content": "",
            "tool_calls": [{"id": "c2", "type": "function", "function": {"name": "go_to", "arguments": "{}"}}],
        },
        {
            "role": "tool",
            "tool_call_id": "c2",
            "content": "Error: the arguments are not valid JSON (Expecting ',' delimiter at character 18): "
            '{"place": "RoomC1". Call go_to again with a JSON object of arguments.',
        },
    ]
    assert bodies[3]["messages"][-1] == {
        "role": "tool",
        "tool_call_id": "c3",
        "content": "Error: there is no tool 'fly'. The tools are: look, go_to, go_to_block, pick_up, put_down, say, wait.",
    }
    # A call written in the text is answered in a user message; an empty reply gets a nudge.
    assert bodies[4]["messages"][-2:] == [
        {"role": "assistant", "content": '{"tool": "go_to", "arguments": {"place": "RoomC1"}}'},
        {
            "role": "user",
            "content": 'Tool results:\ngo_to({"place": "RoomC1"}): Arrived at RoomC1 after 110 ticks. I now see block 11 (Yellow).',
        },
    ]
    assert bodies[5]["messages"][-1] == {
        "role": "user",
        "content": "Your reply was empty. Call one of the tools: look, go_to, go_to_block, pick_up, put_down, say, wait.",
    }
    assert bodies[7]["messages"][-1] == {
        "role": "user",
        "content": "Your reply was cut off at the length limit. Answer with one short tool call.",
    }
    # The history is bounded: the system and first messages, then the last 3 turns whole.
    last = bodies[8]["messages"]
    assert last[:2] == first["messages"]
    assert [m["role"] for m in last[2:]] == ["assistant", "tool", "tool", "assistant", "user", "assistant", "tool"]
    for request in bodies:
        answered = {c["id"] for m in request["messages"] if m["role"] == "assistant" for c in m.get("tool_calls", [])}
        assert all(m["tool_call_id"] in answered for m in request["messages"] if m["role"] == "tool")

    # The look after put_down was not run: the match was over.
    lines = [json.loads(line) for line in log.getvalue().splitlines()]
    assert [line["turn"] for line in lines] == list(range(1, 10))
    assert [c["name"] for c in lines[-1]["calls"]] == ["put_down"]
    assert lines[-1]["calls"][0]["outcome"] == "match_over"
    assert lines[-1]["usage"] == {"prompt_tokens": 4500, "completion_tokens": 154}
    assert lines[6]["finish_reason"] == "length" and lines[6]["calls"] == []
    assert progress.getvalue().splitlines()[0] == "turn 1: look {} -> done"


def test_a_model_without_tools_is_given_them_in_the_prompt(chat_script):
    chat = chat_script(
        [
            (400, {"error": {"message": "registry.ollama.ai/library/gemma3:4b does not support tools", "type": "api_error"}}),
            completion({"content": '```json\n{"tool": "put_down", "arguments": {}}\n```'}, "stop", 50, 5),
        ]
    )
    session = FakeSession({"put_down": [tool_result("The match is over.", "match_over", 5, ended=True)]})
    summary = asyncio.run(agent.play(session, chat.endpoint(api_key="sk-test"), agent.Options(max_turns=5)))
    assert (summary.outcome, summary.turns, summary.tool_calls) == ("match_over", 1, 1)
    first, second = chat.bodies()
    assert "tools" in first and "tools" not in second
    assert "## Calling tools" not in first["messages"][0]["content"]
    assert "## Calling tools" in second["messages"][0]["content"]
    assert chat.requests[1]["headers"]["Authorization"] == "Bearer sk-test"
    assert session.calls == [("put_down", {}, usage(50, 5))]


def test_max_turns_ends_the_loop_and_reports_the_last_tokens(chat_script):
    chat = chat_script([completion({"content": "Hmm."}, "stop", 10, 3), completion({"content": "Let me see."}, "stop", 20, 4)])
    session = FakeSession({"look": [tool_result("I am in RoomA1.", "done", 9)]})
    summary = asyncio.run(agent.play(session, chat.endpoint(), agent.Options(max_turns=2)))
    assert (summary.outcome, summary.turns, summary.tool_calls) == ("max_turns", 2, 0)
    # Without a tool call the tokens would not reach the match result: one look carries them.
    assert session.calls == [("look", {}, usage(30, 7))]
    assert chat.bodies()[1]["messages"][-2:] == [
        {"role": "assistant", "content": "Hmm."},
        {"role": "user", "content": "Act by calling one of the tools: look, go_to, go_to_block, pick_up, put_down, say, wait."},
    ]


def test_a_refused_request_ends_the_loop_with_an_error(chat_script):
    chat = chat_script([(401, {"error": {"message": "Incorrect API key provided"}})])
    summary = asyncio.run(agent.play(FakeSession({}), chat.endpoint(), agent.Options(max_turns=5)))
    assert (summary.outcome, summary.turns) == ("error", 0)
    assert summary.error.startswith("chat endpoint: HTTP 401: ")
    assert "Incorrect API key provided" in summary.error


class FakeMCPError(Exception):
    """Shaped as the SDK's `MCPError`: a JSON-RPC code and message."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(code, message)
        self.code = code
        self.message = message


class FailingSession(FakeSession):
    """A session whose `go_to` calls raise the given errors in turn."""

    def __init__(self, errors: List[Exception]) -> None:
        super().__init__({})
        self.errors = list(errors)

    async def call_tool(self, name: str, arguments: Optional[Dict[str, Any]] = None, *, meta: Optional[Dict[str, Any]] = None) -> Dict[str, Any]:
        self.calls.append((name, arguments, meta))
        raise self.errors.pop(0)


def test_refused_arguments_are_the_models_to_fix_and_a_failing_session_ends_the_loop(chat_script):
    go = completion(native(("c1", "go_to", '{"place": "RoomZ9"}')), "tool_calls", 10, 1)
    chat = chat_script([go] * 5)
    session = FailingSession(
        [FakeMCPError(-32602, "go_to: there is no place RoomZ9")] + [FakeMCPError(-32000, "Connection closed")] * 3
    )
    log = io.StringIO()
    summary = asyncio.run(agent.play(session, chat.endpoint(), agent.Options(max_turns=5, log=log)))
    assert (summary.outcome, summary.turns, summary.error) == ("error", 4, "Error: the tool call failed: Connection closed")
    results = [(c["outcome"], c["result"]) for line in log.getvalue().splitlines() for c in json.loads(line)["calls"]]
    assert results == [("invalid_arguments", "Error: go_to: there is no place RoomZ9")] + [
        ("session_error", "Error: the tool call failed: Connection closed")
    ] * 3


def test_parse_args_passes_the_rest_to_the_server():
    args, server_args = agent.parse_args(["--max-turns", "7", "--bw4t", "./target/release/bw4t mcp", "--", "--map", "fixed", "--seed", "1"])
    assert (args.max_turns, args.bw4t, args.temperature, args.log) == (7, "./target/release/bw4t mcp", None, None)
    assert server_args == ["--map", "fixed", "--seed", "1"]


# ---------------------------------------------------------------------------------------
# The MCP SDK end to end, with a stand-in for `bw4t mcp`

STAND_IN = '''
import json, os
from mcp.server.mcpserver import Context, MCPServer
from mcp.types import CallToolResult, TextContent

server = MCPServer("bw4t-stand-in")

@server.tool()
def put_down(ctx: Context) -> CallToolResult:
    """Put the held block down."""
    usage = dict(ctx.request_context.meta or {}).get("bw4t/usage")
    text = "Delivered. The match is over."
    return CallToolResult(
        content=[TextContent(text=text)],
        structured_content={"outcome": "match_over", "tick": 42, "changes": [text], "ended": True,
                            "usage": usage, "name": os.environ.get("BW4T_NAME")},
    )

@server.prompt()
def play() -> str:
    return "You play BW4T."

server.run()
'''


def test_connect_and_play_through_the_mcp_sdk(chat_script, tmp_path, monkeypatch):
    pytest.importorskip("mcp")
    script = tmp_path / "stand_in.py"
    script.write_text(STAND_IN)
    monkeypatch.setenv("BW4T_NAME", "Agent3")
    chat = chat_script([completion(native(("c1", "put_down", "{}")), "tool_calls", 77, 8)])
    log = io.StringIO()
    summary = asyncio.run(agent.run([sys.executable, str(script)], chat.endpoint(), agent.Options(max_turns=3, log=log)))
    assert (summary.outcome, summary.turns, summary.tool_calls, summary.tick) == ("match_over", 1, 1, 42)
    assert chat.bodies()[0]["messages"][0] == {"role": "system", "content": "You play BW4T."}
    assert [t["function"]["name"] for t in chat.bodies()[0]["tools"]] == ["put_down"]
    # The server saw the environment (BW4T_NAME) and the usage `_meta`.
    assert json.loads(log.getvalue())["calls"][0]["result"] == "Delivered. The match is over."

    async def structured() -> Dict[str, Any]:
        async with agent.connect([sys.executable, str(script)]) as session:
            return agent.as_dict(await session.call_tool("put_down", {}, meta=usage(5, 6)))["structuredContent"]

    seen = asyncio.run(structured())
    assert (seen["name"], seen["usage"]) == ("Agent3", {"prompt_tokens": 5, "completion_tokens": 6})
