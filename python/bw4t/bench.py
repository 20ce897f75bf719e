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
"""

from __future__ import annotations

import argparse
import asyncio
import json
import subprocess
import sys
import time
from typing import Dict, List, Optional

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


def bench_tcp(ticks: int, seed: int) -> Dict:
    """3 TCP-client players in lockstep on a `bw4t serve` child, one step per tick."""
    from . import AsyncClient

    server = subprocess.Popen(
        [sys.executable, "-m", "bw4t", "serve", "--once", "--mode", "lockstep", "--port", "0"]
        + ["--robots", str(ROBOTS), "--seed", str(seed), "--max-ticks", str(ticks + 10)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert server.stdout is not None
        first = server.stdout.readline().strip()
        if not first.startswith("listening on "):
            raise RuntimeError(f"bw4t serve did not start: {first!r}")
        host, port = first.removeprefix("listening on ").rsplit(":", 1)

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


def main(argv: Optional[List[str]] = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bw4t.bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20000, help="steps of the single env per setting")
    parser.add_argument("--vector-steps", type=int, default=400, help="steps of each vector per setting")
    parser.add_argument("--tcp-ticks", type=int, default=3000, help="ticks of the TCP client path")
    parser.add_argument("--threads", type=int, default=None, help="threads of the vector (default: cores)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--cases", default="single,vector,tcp,memory", help="comma-separated: single, vector, tcp, memory"
    )
    args = parser.parse_args(argv)
    cases = set(args.cases.split(","))
    unknown = cases - {"single", "vector", "tcp", "memory"}
    if unknown:
        parser.error(f"unknown case(s): {', '.join(sorted(unknown))}")
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


if __name__ == "__main__":
    main()
