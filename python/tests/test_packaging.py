"""What `pip install bw4t` gives without the `rl` extra: the client, `bw4t.sim` and the
command work with Gymnasium and PettingZoo absent, and `bw4t.env` says how to get them."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

WITHOUT_RL = textwrap.dedent(
    """
    import sys
    # As if neither were installed: importing either raises ModuleNotFoundError.
    sys.modules["gymnasium"] = None
    sys.modules["pettingzoo"] = None
    import bw4t
    from bw4t import Client, AsyncClient, BeliefBase
    import bw4t.sim
    match = bw4t.sim.Match(map="fixed", players=1, teammates=2, seed=3)
    before = match.digest()
    match.step()
    assert match.digest() != before
    try:
        import bw4t.env
    except ImportError as error:
        print(error)
    else:
        raise SystemExit("bw4t.env imported without Gymnasium")
    assert "gymnasium" not in sys.modules or sys.modules["gymnasium"] is None
    """
)


def test_the_client_and_the_simulation_need_no_learning_packages():
    done = subprocess.run([sys.executable, "-c", WITHOUT_RL], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    said = done.stdout.strip()
    assert "pip install 'bw4t[rl]'" in said and "gymnasium" in said, said


def test_the_base_install_asks_only_for_numpy():
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in Python 3.11 and newer")
    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    project = tomllib.loads(pyproject.read_text())["project"]
    assert [d.split(">")[0] for d in project["dependencies"]] == ["numpy"]
    rl = project["optional-dependencies"]["rl"]
    assert sorted(d.split(">")[0] for d in rl) == ["gymnasium", "pettingzoo"]
    for extra in ("test", "train"):
        assert "bw4t[rl]" in project["optional-dependencies"][extra], extra
