"""``bw4t.eval``: a Python policy on a tier of the suite, through the learning environment,
scored by ``bw4t eval score``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bw4t import eval as bw4t_eval


class FirstValid:
    """Takes the lowest-numbered valid action that is not `wait` (deterministic)."""

    def __init__(self):
        self.seeds = []

    def reset(self, seed):
        self.seeds.append(seed)

    def __call__(self, observations):
        return {name: int(np.flatnonzero(o["action_mask"][1:])[0] + 1) if o["action_mask"][1:].any() else 0
                for name, o in observations.items()}


def test_a_policy_is_played_on_every_task_and_scored(tmp_path):
    policy = FirstValid()
    tasks = bw4t_eval.tasks("pair")
    row = bw4t_eval.evaluate(policy, "pair", agent="python:first-valid", out=str(tmp_path / "a"), meta={"name": "fv"})
    assert (row["tier"], row["split"], row["matches"], row["tasks"]) == ("pair", "dev", len(tasks), len(tasks))
    assert row["agent"]["command"] == "python:first-valid" and row["agent"]["name"] == "fv"
    assert policy.seeds == [t["seed"] for t in tasks]
    lines = [json.loads(l) for l in (tmp_path / "a" / "outcomes.jsonl").read_text().splitlines()]
    assert [l["key"] for l in lines] == [t["key"] for t in tasks]
    # The built-in teammate finishes the sequence whatever its partner does.
    assert row["completion"] > 0 and len(row["digest"]) == 64
    again = bw4t_eval.evaluate(FirstValid(), "pair", agent="python:first-valid", out=str(tmp_path / "b"))
    assert again["digest"] == row["digest"], "the same policy plays the same matches"


def test_a_tier_without_messages_refuses_a_say_action():
    from bw4t import _spec

    task = bw4t_eval.tasks("silent")[0]
    seats = ["learner" if s == "agent" else s.split(":", 1)[1] for s in task["seats"]]
    layout = _spec.make_spec(task["map"], seats, 10, task["max_ticks"], bw4t_eval.SLOTS, None).action_layout
    say = next(first for name, first, _ in layout if name.startswith("say_"))

    def talker(observations):
        return {name: say for name in observations}

    with pytest.raises(ValueError, match="allows no messages"):
        bw4t_eval.play(task, talker)


def test_a_bad_policy_or_tier_is_named(tmp_path):
    with pytest.raises(ValueError, match="MODULE:NAME"):
        bw4t_eval.load_policy("nocolon")
    with pytest.raises(RuntimeError, match="unknown tier 'nope'"):
        bw4t_eval.tasks("nope")
    assert bw4t_eval.main(["solo", "--policy", "json:nothing_here"]) == 1
