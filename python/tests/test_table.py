"""The client's knowledge of percepts and actions agrees with the protocol's table
(``protocol/schema/table.json``, written from the Rust code)."""

from __future__ import annotations

import json
from pathlib import Path

from bw4t import beliefs, core

TABLE = json.loads((Path(__file__).resolve().parents[2] / "protocol" / "schema" / "table.json").read_text("utf-8"))


def names(rows, **where):
    return {r["name"] for r in rows if all(r[k] == v for k, v in where.items())}


def test_single_valued_percepts_are_those_sent_on_change():
    assert beliefs.SINGLE_VALUED == names(TABLE["percepts"], send="on_change")


def test_event_percepts_are_those_sent_as_events():
    assert beliefs.EVENTS == names(TABLE["percepts"], send="event")


def test_durative_actions_are_those_the_table_marks():
    assert core.DURATIVE_ACTIONS == names(TABLE["actions"], durative=True)


def test_every_action_has_a_helper_with_its_name():
    from bw4t._base import ClientBase

    helpers = {"goTo": "go_to", "goToBlock": "go_to_block", "pickUp": "pick_up", "putDown": "put_down",
               "sendMessage": "send_message"}
    assert set(helpers) == names(TABLE["actions"])
    for action, helper in helpers.items():
        assert callable(getattr(ClientBase, helper, None)), f"{action}: no {helper}()"
