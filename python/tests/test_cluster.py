"""Cluster job files: the Kubernetes manifests `bw4t tournament k8s` writes are valid
against the Kubernetes API's own schemas (kubernetes-validate carries them, offline),
for the oldest and newest versions it knows; a broken one is caught."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

kubernetes_validate = pytest.importorskip("kubernetes_validate", reason="kubernetes-validate is not installed")
pytest.importorskip("kubernetes_validate.utils")

CONFIG = 'maps = ["fixed"]\nseeds = 2\n\n[[team]]\nname = "coop"\nagents = "builtin"\n'
#: The oldest and newest Kubernetes versions whose schemas the package carries (Indexed
#: Jobs are generally available from 1.24).
_known = kubernetes_validate.utils.all_versions()
VERSIONS = [_known[0], kubernetes_validate.utils.latest_version()]


def manifests(bw4t_bin: str, tmp_path: Path) -> dict:
    config = tmp_path / "t.toml"
    config.write_text(CONFIG)
    out = subprocess.run(
        [bw4t_bin, "tournament", "k8s", str(config), "--completions", "4", "--out", str(tmp_path / "k8s")],
        capture_output=True, text=True, timeout=60,
    )
    assert out.returncode == 0, out.stderr
    return {p.name: json.loads(p.read_text()) for p in sorted((tmp_path / "k8s").glob("*.json"))}


def test_the_manifests_validate_against_the_kubernetes_schemas(bw4t_bin: str, tmp_path: Path) -> None:
    files = manifests(bw4t_bin, tmp_path)
    assert sorted(files) == ["configmap.json", "merge-job.json", "shards-job.json"]
    for version in VERSIONS:
        for name, manifest in files.items():
            # strict: no field the schema does not know, so a misspelt key is an error too.
            kubernetes_validate.validate(manifest, version, strict=True)
    assert files["shards-job.json"]["spec"]["completionMode"] == "Indexed"


def test_a_broken_manifest_is_caught(bw4t_bin: str, tmp_path: Path) -> None:
    job = manifests(bw4t_bin, tmp_path)["shards-job.json"]
    job["spec"]["template"]["spec"]["containers"][0]["comand"] = ["typo"]
    with pytest.raises(kubernetes_validate.ValidationError):
        kubernetes_validate.validate(job, VERSIONS[-1], strict=True)
