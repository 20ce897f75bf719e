"""A language model plays one BW4T robot through `bw4t mcp`, over any OpenAI-compatible API.

The agent starts `bw4t mcp` as a child process (MCP over stdio), turns the server's tools
into the chat API's function definitions, takes the server's `play` prompt as the system
message, and loops: the model answers with tool calls, the agent runs them on the server
and hands the results back, until a result says the match is over or `--max-turns` runs
out. It needs the MCP Python SDK, on Python 3.10 or newer (`pip install "bw4t[mcp]"`, or
`pip install "mcp>=2.3"`); the chat API is spoken with the standard library alone.

Configuration, from the environment: `OPENAI_BASE_URL` (default
`https://api.openai.com/v1`), `OPENAI_MODEL` (required), `OPENAI_API_KEY` (not needed by
most local servers).

    # OpenAI
    OPENAI_API_KEY=sk-... OPENAI_MODEL=gpt-4.1-mini python3 python/examples/llm_agent.py

    # Ollama (or llama.cpp's llama-server, vLLM: their /v1 base URL)
    OPENAI_BASE_URL=http://localhost:11434/v1 OPENAI_MODEL=qwen3:8b \\
        python3 python/examples/llm_agent.py --log turns.jsonl

    # Options after `--` go to `bw4t mcp`: the map, the seed, built-in teammates
    python3 python/examples/llm_agent.py -- --map fixed --seed 1 --teammates coop,coop

    # As one player of a served match: `bw4t run` gives the agent BW4T_HOST, BW4T_PORT,
    # BW4T_NAME and BW4T_TOKEN, which reach `bw4t mcp` through the environment
    bw4t run --map fixed --team builtin:coop --robots 2 \\
        --agent "python3 python/examples/llm_agent.py"

A model without tool calling (Ollama answers "does not support tools") is detected on the
first request; the tools are then described in the system message instead and the model
answers with a JSON object, `{"tool": "go_to", "arguments": {"place": "RoomC1"}}`, which
is also accepted from any model that writes one in its text.

Output: one line per turn on stderr, `--log FILE` a JSON object per turn, and at the end
one JSON summary line on stdout (outcome, turns, tool calls, tokens, wall seconds). The
token counts the API reports are also sent to the server with every tool call
(`_meta["bw4t/usage"]`), which puts them in the match result.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import shlex
import sys
import time
import urllib.error
import urllib.request
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import IO, Any, AsyncIterator, Dict, Iterator, List, Mapping, Optional, Protocol, Sequence, Tuple

DEFAULT_BASE_URL = "https://api.openai.com/v1"
#: The `_meta` key the server reads this agent's cumulative token counts from.
USAGE_META_KEY = "bw4t/usage"
#: The first user message; the system message (the server's `play` prompt) says the rest.
START_MESSAGE = "The match has started. Call look to see where you are, then play."
#: Session errors in a row after which the server is taken to be gone.
MAX_SESSION_ERRORS = 3
#: The JSON-RPC error code of arguments the server refused (an unknown place, say): the
#: model's mistake to fix, unlike a session that fails.
INVALID_PARAMS = -32602
#: HTTP statuses worth a retry: rate limits and an overloaded or restarting server.
RETRY_STATUSES = (429, 500, 502, 503, 504)


@dataclass(frozen=True)
class ToolCall:
    """One call the model asked for; `error` says why its arguments could not be used."""

    id: str
    name: str
    arguments: Dict[str, Any]
    error: Optional[str] = None


@dataclass(frozen=True)
class Reply:
    """What a chat completion asked for. `native` is False when the calls came from text."""

    text: str
    tool_calls: List[ToolCall]
    finish_reason: Optional[str]
    native: bool


class Session(Protocol):
    """The part of `mcp.ClientSession` the loop uses, so that tests can pass a fake."""

    async def list_tools(self) -> Any: ...

    async def get_prompt(self, name: str, arguments: Optional[Dict[str, str]] = None) -> Any: ...

    async def call_tool(
        self, name: str, arguments: Optional[Dict[str, Any]] = None, *, meta: Optional[Dict[str, Any]] = None
    ) -> Any: ...


class ChatError(Exception):
    """The chat endpoint refused a request (`status` 0: it could not be reached)."""

    def __init__(self, status: int, body: str) -> None:
        super().__init__(f"chat endpoint: HTTP {status}: {body[:500]}" if status else f"chat endpoint: {body}")
        self.status = status
        self.body = body


@dataclass
class ChatEndpoint:
    """An OpenAI-compatible `/chat/completions` endpoint, spoken with urllib alone."""

    base_url: str
    model: str
    api_key: Optional[str] = None
    temperature: Optional[float] = None
    timeout: float = 300.0
    retries: int = 3

    def complete(self, messages: Sequence[Mapping[str, Any]], tools: Optional[Sequence[Mapping[str, Any]]]) -> Dict[str, Any]:
        """One chat completion (blocking). Retries rate limits and unreachable servers with backoff."""
        body: Dict[str, Any] = {"model": self.model, "messages": list(messages)}
        if tools:
            body["tools"] = list(tools)
        # Omitted unless asked for: some models accept only their default temperature.
        if self.temperature is not None:
            body["temperature"] = self.temperature
        headers = {"Content-Type": "application/json"}
        if self.api_key:
            headers["Authorization"] = f"Bearer {self.api_key}"
        request = urllib.request.Request(
            self.base_url.rstrip("/") + "/chat/completions", data=json.dumps(body).encode(), headers=headers
        )
        for attempt in range(self.retries + 1):
            try:
                with urllib.request.urlopen(request, timeout=self.timeout) as response:
                    return json.loads(response.read())
            except urllib.error.HTTPError as e:
                error = ChatError(e.code, e.read().decode("utf-8", "replace"))
                if e.code not in RETRY_STATUSES:
                    raise error from None
            except (urllib.error.URLError, TimeoutError, ConnectionError) as e:
                error = ChatError(0, str(getattr(e, "reason", e)))
            except json.JSONDecodeError as e:
                raise ChatError(200, f"the reply is not JSON: {e}") from None
            if attempt < self.retries:
                time.sleep(2**attempt)
        raise error


@dataclass
class Usage:
    """Token counts summed over the whole match, as the server wants them: cumulative."""

    prompt_tokens: int = 0
    completion_tokens: int = 0

    def add(self, usage: Any) -> None:
        """Adds a response's `usage`; servers that leave it out (or send nulls) count nothing."""
        if isinstance(usage, Mapping):
            self.prompt_tokens += int(usage.get("prompt_tokens") or 0)
            self.completion_tokens += int(usage.get("completion_tokens") or 0)

    def as_dict(self) -> Dict[str, int]:
        return {"prompt_tokens": self.prompt_tokens, "completion_tokens": self.completion_tokens}


@dataclass
class Options:
    """How the loop plays: turns, how much history the model sees, where the turn log goes."""

    max_turns: int = 200
    keep_turns: int = 12
    log: Optional[IO[str]] = None
    progress: Optional[IO[str]] = None


@dataclass
class Summary:
    """How the match went for this agent; printed as the final JSON line."""

    outcome: str = "max_turns"
    turns: int = 0
    tool_calls: int = 0
    tick: Optional[int] = None
    usage: Usage = field(default_factory=Usage)
    wall_seconds: float = 0.0
    error: Optional[str] = None

    def as_dict(self) -> Dict[str, Any]:
        line: Dict[str, Any] = {
            "summary": True,
            "outcome": self.outcome,
            "turns": self.turns,
            "tool_calls": self.tool_calls,
            "tick": self.tick,
            **self.usage.as_dict(),
            "wall_seconds": round(self.wall_seconds, 3),
        }
        if self.error:
            line["error"] = self.error
        return line


# ---------------------------------------------------------------------------------------
# Reading model replies (pure functions)


def parse_reply(response: Mapping[str, Any]) -> Reply:
    """The text and tool calls of a chat completion, in whichever style the server wrote them.

    Standard `tool_calls` come first (arguments as a JSON string, or an object as some
    servers send); without them, a JSON object in the text (bare, fenced, or inside other
    words) naming a tool is taken as a call, for models without tool calling. Arguments
    that cannot be read give a `ToolCall` with `error` set, so that the model is told.
    """
    choices = response.get("choices") or []
    if not choices:
        return Reply("", [], None, native=False)
    choice = choices[0]
    message = choice.get("message") or {}
    text = content_text(message.get("content"))
    finish_reason = choice.get("finish_reason")
    raw_calls = message.get("tool_calls") or []
    if raw_calls:
        calls = [native_call(raw, idx) for idx, raw in enumerate(raw_calls)]
        return Reply(text, calls, finish_reason, native=True)
    return Reply(text, calls_in_text(text), finish_reason, native=False)


def content_text(content: Any) -> str:
    """A message's content as text: a string, or the text parts of a list of parts."""
    if isinstance(content, str):
        return content
    if isinstance(content, list):
        return "".join(part.get("text", "") for part in content if isinstance(part, Mapping))
    return ""


def native_call(raw: Mapping[str, Any], idx: int) -> ToolCall:
    """One entry of `tool_calls`. A missing id gets one, which the tool message must echo."""
    function = raw.get("function") or {}
    name = str(function.get("name") or "")
    call_id = str(raw.get("id") or f"call_{idx}")
    arguments, error = read_arguments(function.get("arguments"))
    return ToolCall(call_id, name, arguments, error)


def read_arguments(raw: Any) -> Tuple[Dict[str, Any], Optional[str]]:
    """Arguments as an object: from a JSON string, an object, or nothing (no arguments)."""
    if raw is None or (isinstance(raw, str) and not raw.strip()):
        return {}, None
    if isinstance(raw, str):
        try:
            raw = json.loads(raw)
        except json.JSONDecodeError as e:
            return {}, f"the arguments are not valid JSON ({e.msg} at character {e.pos}): {raw[:300]}"
    if raw is None:
        return {}, None
    if not isinstance(raw, dict):
        return {}, f"the arguments must be a JSON object, not {json.dumps(raw)[:300]}"
    return raw, None


def calls_in_text(text: str) -> List[ToolCall]:
    """Tool calls written as JSON in a reply's text: the first JSON value that names a tool."""
    for value in json_values(text):
        calls = calls_in_json(value)
        if calls:
            return [ToolCall(f"text_{idx}", name, *read_arguments(args)) for idx, (name, args) in enumerate(calls)]
    return []


FENCE = re.compile(r"```[A-Za-z0-9_-]*\s*\n?(.*?)```", re.DOTALL)
OPENING = re.compile(r"[{\[]")


def json_values(text: str) -> Iterator[Any]:
    """JSON values in text: fenced blocks first, then every object or array found by scanning."""
    for block in FENCE.findall(text):
        try:
            yield json.loads(block)
        except json.JSONDecodeError:
            pass
    decoder = json.JSONDecoder()
    start = 0
    while True:
        match = OPENING.search(text, start)
        if match is None:
            return
        try:
            value, end = decoder.raw_decode(text, match.start())
        except json.JSONDecodeError:
            start = match.start() + 1
            continue
        yield value
        start = end


def calls_in_json(value: Any) -> List[Tuple[str, Any]]:
    """(name, arguments) pairs in the shapes models write: `{"tool"|"name": ..., "arguments"|
    "args"|"parameters": ...}`, OpenAI's own `{"function": {...}}`, `{"tool_calls": [...]}`,
    or a list of these."""
    if isinstance(value, list):
        return [call for item in value for call in calls_in_json(item)]
    if not isinstance(value, dict):
        return []
    if isinstance(value.get("tool_calls"), list):
        return calls_in_json(value["tool_calls"])
    if isinstance(value.get("function"), dict):
        return calls_in_json(value["function"])
    name = value.get("tool", value.get("name"))
    if not isinstance(name, str) or not name:
        return []
    for key in ("arguments", "args", "parameters", "input"):
        if key in value:
            return [(name, value[key])]
    return [(name, {})]


# ---------------------------------------------------------------------------------------
# MCP results and tool definitions (pure functions)


def as_dict(result: Any) -> Dict[str, Any]:
    """An SDK result (a pydantic model) or a fake's dict, in the wire's camelCase form."""
    if hasattr(result, "model_dump"):
        return result.model_dump(by_alias=True, mode="json", exclude_none=True)
    return dict(result)


def openai_tools(tools: Sequence[Mapping[str, Any]]) -> List[Dict[str, Any]]:
    """MCP tool definitions (`tools/list`) as chat-API function definitions.

    The input schema becomes `parameters` as it is, less `$schema` (which some servers
    refuse), and always with `properties`, which OpenAI requires even when empty.
    """
    return [
        {
            "type": "function",
            "function": {
                "name": tool["name"],
                "description": tool.get("description") or "",
                "parameters": function_parameters(tool.get("inputSchema") or {}),
            },
        }
        for tool in tools
    ]


def function_parameters(schema: Mapping[str, Any]) -> Dict[str, Any]:
    """A tool's input schema as function parameters (see `openai_tools`)."""
    parameters = {key: value for key, value in schema.items() if key != "$schema"}
    parameters.setdefault("type", "object")
    parameters.setdefault("properties", {})
    return parameters


def tools_in_prompt(tools: Sequence[Mapping[str, Any]]) -> str:
    """The tools described in words, for models without tool calling, and how to call one."""
    lines = ["", "## Calling tools", "", "Call one tool per reply by answering with a JSON object only:",
             '{"tool": "NAME", "arguments": {...}}', "", "The tools:"]
    for tool in tools:
        properties = (tool.get("inputSchema") or {}).get("properties") or {}
        required = set((tool.get("inputSchema") or {}).get("required") or [])
        args = ", ".join(f"{name}{'' if name in required else '?'}: {schema_type(spec)}" for name, spec in properties.items())
        lines.append(f"- {tool['name']}({args}): {tool.get('description') or ''}".rstrip())
    return "\n".join(lines)


def schema_type(spec: Mapping[str, Any]) -> str:
    """A property's JSON type in a word (`integer`, not `["integer", "null"]`)."""
    kind = spec.get("type", "any")
    if isinstance(kind, list):
        kind = next((k for k in kind if k != "null"), "any")
    return str(kind)


def prompt_text(prompt: Mapping[str, Any]) -> str:
    """The text of a `prompts/get` result, its messages joined, to use as the system message."""
    texts = [
        message.get("content", {}).get("text", "")
        for message in prompt.get("messages") or []
        if message.get("content", {}).get("type") == "text"
    ]
    return "\n\n".join(text for text in texts if text)


def result_text(result: Mapping[str, Any]) -> str:
    """What the model reads of a tool result: its text (which already says what changed)."""
    text = "\n".join(block.get("text", "") for block in result.get("content") or [] if block.get("type") == "text")
    if not text and result.get("structuredContent") is not None:
        text = json.dumps(result["structuredContent"])
    return f"Error: {text}" if result.get("isError") else text


def result_outcome(result: Mapping[str, Any]) -> Tuple[str, Optional[int], bool]:
    """(outcome, tick, ended) of a tool result, from its `structuredContent`."""
    structured = result.get("structuredContent")
    if not isinstance(structured, Mapping):
        return ("error" if result.get("isError") else "unknown"), None, False
    outcome = str(structured.get("outcome", "unknown"))
    tick = structured.get("tick")
    ended = outcome == "match_over" or structured.get("ended") is True
    return outcome, tick if isinstance(tick, int) else None, ended


# ---------------------------------------------------------------------------------------
# The loop


async def play(session: Session, chat: ChatEndpoint, options: Options) -> Summary:
    """Plays until the match is over or the turns run out; the session is any `Session`."""
    started = time.monotonic()
    summary = Summary()
    tools = [dict(tool) for tool in as_dict(await session.list_tools()).get("tools") or []]
    names = [tool["name"] for tool in tools]
    prompt = prompt_text(as_dict(await session.get_prompt("play")))
    function_defs: Optional[List[Dict[str, Any]]] = openai_tools(tools)
    system = {"role": "system", "content": prompt}
    start = {"role": "user", "content": START_MESSAGE}
    # Whole turns are kept or dropped, so a tool message never loses its assistant message.
    turns: List[List[Dict[str, Any]]] = []
    session_errors = 0
    reported: Dict[str, int] = {}
    try:
        while summary.turns < options.max_turns:
            messages = [system, start] + [m for turn in turns[-options.keep_turns:] for m in turn]
            asked = time.monotonic()
            try:
                response = await asyncio.to_thread(chat.complete, messages, function_defs)
            except ChatError as e:
                if function_defs is None or e.status != 400 or "tool" not in e.body.lower():
                    raise
                # The model cannot call tools: describe them in words and read calls from text.
                note(options, f"the endpoint refused tools ({e.body[:200]}); describing them in the prompt")
                function_defs = None
                system = {"role": "system", "content": prompt + "\n" + tools_in_prompt(tools)}
                continue
            summary.turns += 1
            summary.usage.add(response.get("usage"))
            reply = parse_reply(response)
            turn, records, ended = await act(session, reply, names, summary)
            session_errors = session_errors + 1 if records and all(r["outcome"] == "session_error" for r in records) else 0
            if records:
                reported = summary.usage.as_dict()
            turns.append(turn)
            log_turn(options, summary, reply, records, time.monotonic() - asked)
            if ended:
                summary.outcome = "match_over"
                break
            if session_errors >= MAX_SESSION_ERRORS:
                summary.outcome = "error"
                summary.error = records[-1]["result"]
                break
        if summary.outcome == "max_turns" and session_errors == 0 and reported != summary.usage.as_dict():
            # The last turns' tokens reach the match result only with a tool call.
            await session.call_tool("look", {}, meta=usage_meta(summary.usage))
    except ChatError as e:
        summary.outcome = "error"
        summary.error = str(e)
    summary.wall_seconds = time.monotonic() - started
    return summary


async def act(
    session: Session, reply: Reply, names: Sequence[str], summary: Summary
) -> Tuple[List[Dict[str, Any]], List[Dict[str, Any]], bool]:
    """Runs a reply's tool calls. Returns the turn's messages, a record per call, and whether
    the match is over (later calls of the reply are then not run)."""
    records: List[Dict[str, Any]] = []
    ended = False
    for call in reply.tool_calls:
        if ended:
            break
        if call.error:
            outcome, text = "bad_arguments", f"Error: {call.error}. Call {call.name or 'the tool'} again with a JSON object of arguments."
        elif call.name not in names:
            outcome, text = "unknown_tool", f"Error: there is no tool {call.name!r}. The tools are: {', '.join(names)}."
        else:
            summary.tool_calls += 1
            outcome, text, ended = await call_tool(session, call, summary)
        records.append({"id": call.id, "name": call.name, "arguments": call.arguments, "outcome": outcome, "result": text})
    return turn_messages(reply, records, names), records, ended


async def call_tool(session: Session, call: ToolCall, summary: Summary) -> Tuple[str, str, bool]:
    """One call on the server, with the token counts so far. An error is told to the model."""
    try:
        result = as_dict(await session.call_tool(call.name, call.arguments, meta=usage_meta(summary.usage)))
    except Exception as e:  # noqa: BLE001 - whatever failed, the model is told and the loop goes on
        message = getattr(e, "message", None) or str(e)
        if getattr(e, "code", None) == INVALID_PARAMS:
            return "invalid_arguments", f"Error: {message}", False
        return "session_error", f"Error: the tool call failed: {message}", False
    outcome, tick, ended = result_outcome(result)
    if tick is not None:
        summary.tick = tick
    return outcome, result_text(result), ended


def usage_meta(usage: Usage) -> Dict[str, Any]:
    """The `_meta` of a tool call: this agent's cumulative token counts."""
    return {USAGE_META_KEY: usage.as_dict()}


def turn_messages(reply: Reply, records: Sequence[Mapping[str, Any]], names: Sequence[str]) -> List[Dict[str, Any]]:
    """The messages a turn adds to the conversation.

    Native calls are echoed in the assistant message and answered by `tool` messages (their
    unreadable arguments echoed as `{}`, which every server accepts). Calls read from text
    are answered in a user message, since there is no call id to answer. A reply without
    calls gets a nudge: it was cut off, empty, or only talk.
    """
    if reply.native:
        assistant: Dict[str, Any] = {
            "role": "assistant",
            "content": reply.text,
            "tool_calls": [
                {
                    "id": call.id,
                    "type": "function",
                    "function": {"name": call.name, "arguments": json.dumps(call.arguments)},
                }
                for call in reply.tool_calls[: len(records)]
            ],
        }
        return [assistant] + [{"role": "tool", "tool_call_id": r["id"], "content": r["result"]} for r in records]
    messages: List[Dict[str, Any]] = [{"role": "assistant", "content": reply.text}] if reply.text else []
    if records:
        results = "\n\n".join(f"{r['name']}({json.dumps(r['arguments'])}): {r['result']}" for r in records)
        return messages + [{"role": "user", "content": f"Tool results:\n{results}"}]
    if reply.finish_reason == "length":
        nudge = "Your reply was cut off at the length limit. Answer with one short tool call."
    elif not reply.text.strip():
        nudge = f"Your reply was empty. Call one of the tools: {', '.join(names)}."
    else:
        nudge = f"Act by calling one of the tools: {', '.join(names)}."
    return messages + [{"role": "user", "content": nudge}]


def log_turn(
    options: Options, summary: Summary, reply: Reply, records: Sequence[Mapping[str, Any]], seconds: float
) -> None:
    """One line on the progress stream and one JSON object in the turn log."""
    calls = "; ".join(f"{r['name']} {json.dumps(r['arguments'])} -> {r['outcome']}" for r in records)
    what = calls or f"no tool call ({reply.finish_reason or 'no finish reason'}): {reply.text[:80]!r}"
    note(options, f"turn {summary.turns}: {what}")
    if options.log is not None:
        line = {
            "turn": summary.turns,
            "tick": summary.tick,
            "seconds": round(seconds, 3),
            "finish_reason": reply.finish_reason,
            "text": reply.text,
            "calls": list(records),
            "usage": summary.usage.as_dict(),
        }
        options.log.write(json.dumps(line) + "\n")
        options.log.flush()


def note(options: Options, text: str) -> None:
    if options.progress is not None:
        print(text, file=options.progress, flush=True)


# ---------------------------------------------------------------------------------------
# The command


@asynccontextmanager
async def connect(command: Sequence[str]) -> AsyncIterator[Session]:
    """An MCP session with `bw4t mcp` started as a child process.

    The child gets this process's environment (so `BW4T_HOST`, ... from `bw4t run` make it
    join that match), less the API key, which it has no use for. The SDK is imported here,
    so that the rest of this file works without it.
    """
    from mcp import ClientSession, StdioServerParameters
    from mcp.client.stdio import stdio_client

    env = {key: value for key, value in os.environ.items() if key != "OPENAI_API_KEY"}
    params = StdioServerParameters(command=command[0], args=list(command[1:]), env=env)
    async with stdio_client(params) as (read, write):
        async with ClientSession(read, write) as session:
            await session.initialize()
            yield session


async def run(command: Sequence[str], chat: ChatEndpoint, options: Options) -> Summary:
    async with connect(command) as session:
        return await play(session, chat, options)


def parse_args(argv: Sequence[str]) -> Tuple[argparse.Namespace, List[str]]:
    """The agent's options, and the arguments after `--`, which go to `bw4t mcp`."""
    argv = list(argv)
    server_args = argv[argv.index("--") + 1:] if "--" in argv else []
    own = argv[: argv.index("--")] if "--" in argv else argv
    parser = argparse.ArgumentParser(
        description="An LLM plays one BW4T robot through `bw4t mcp` (OPENAI_BASE_URL, OPENAI_MODEL, OPENAI_API_KEY).",
        epilog="Arguments after -- are passed to the MCP server command.",
    )
    parser.add_argument("--bw4t", default="bw4t mcp", help="the command that starts the MCP server (default: %(default)s)")
    parser.add_argument("--max-turns", type=int, default=200, help="chat completions at most (default: %(default)s)")
    parser.add_argument("--keep-turns", type=int, default=12, help="past turns the model sees (default: %(default)s)")
    parser.add_argument("--temperature", type=float, default=None, help="sampling temperature (default: the model's)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per chat request (default: %(default)s)")
    parser.add_argument("--log", metavar="FILE", help="write a JSON line per turn to FILE")
    return parser.parse_args(own), server_args


def main(argv: Optional[Sequence[str]] = None) -> int:
    args, server_args = parse_args(sys.argv[1:] if argv is None else argv)
    model = os.environ.get("OPENAI_MODEL")
    if not model:
        print("llm_agent: set OPENAI_MODEL to the model's name (and OPENAI_BASE_URL for a local server)", file=sys.stderr)
        return 2
    chat = ChatEndpoint(
        base_url=os.environ.get("OPENAI_BASE_URL") or DEFAULT_BASE_URL,
        model=model,
        api_key=os.environ.get("OPENAI_API_KEY") or None,
        temperature=args.temperature,
        timeout=args.timeout,
    )
    command = shlex.split(args.bw4t) + server_args
    log = open(args.log, "w", encoding="utf-8") if args.log else None
    try:
        options = Options(max_turns=args.max_turns, keep_turns=args.keep_turns, log=log, progress=sys.stderr)
        summary = asyncio.run(run(command, chat, options))
    except Exception as e:  # noqa: BLE001 - the server would not start or went away: say so in one line
        summary = Summary(outcome="error", error=f"MCP server {shlex.join(command)!r}: {innermost(e)}")
        print(f"llm_agent: {summary.error}", file=sys.stderr)
    finally:
        if log is not None:
            log.close()
    print(json.dumps({**summary.as_dict(), "model": model}), flush=True)
    return 1 if summary.outcome == "error" else 0


def innermost(error: BaseException) -> BaseException:
    """The error inside the task groups' exception groups, which alone says what happened."""
    while isinstance(getattr(error, "exceptions", None), tuple) and len(error.exceptions) == 1:
        error = error.exceptions[0]
    return error


if __name__ == "__main__":
    sys.exit(main())
