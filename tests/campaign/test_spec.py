"""Campaign files: every mistake is one clear error naming the file and key, before anything runs."""

from __future__ import annotations

import pytest

from navlog.campaign.runner import run_campaign
from navlog.campaign.spec import load_campaign
from navlog.errors import ConfigError
from tests.campaign.campaign_files import BASE, write


def test_a_campaign_file_loads_typed(tmp_path):
    spec = load_campaign(write(tmp_path, BASE + "seeds: [3, 4]\nroutes: {kind: random, min_distance: 3}\n"))
    assert spec.seeds == [3, 4] and spec.routes.min_distance == 3.0 and spec.baseline_variant == "a"
    assert spec.worlds[0].params == {"doors": 0, "length": 6.0}
    assert load_campaign(write(tmp_path, BASE + "max_duration: 1\n")).max_duration == 1.0  # the shortest
    assert load_campaign(write(tmp_path, BASE + "max_duration: 86400\n")).max_duration == 86400.0


@pytest.mark.parametrize(
    "extra, message",
    [
        ("seed: [1]\n", r"c.yaml: seed: unknown key \(did you mean 'seeds'\?\)"),
        ("localization: amlc\n", r"c.yaml: localization: 'amlc' is not one of .*did you mean 'amcl'"),
        ("baseline: b\n", r"baseline 'b' is not a variant"),
        ("routes: {min_distanse: 3}\n", r"routes.min_distanse: unknown key \(did you mean 'min_distance'\?\)"),
        ("max_duration: 1.0e-9\n", r"c.yaml: max_duration: 1e-09 is out of range: must be >= 1.0$"),
        ("max_duration: .nan\n", r"c.yaml: max_duration: nan is out of range: must be >= 1.0$"),
        ("max_duration: 86401\n", r"c.yaml: max_duration: 86401.0 is out of range: must be <= 86400.0$"),
    ],
)
def test_bad_keys_name_the_file_and_key(tmp_path, extra, message):
    with pytest.raises(ConfigError, match=message):
        load_campaign(write(tmp_path, BASE + extra))


def test_bad_input_fails_before_any_run(tmp_path):
    out = tmp_path / "out"
    bad_set = BASE.replace("nav_go2}", "nav_go2, set: ['FollowPath.desired_linear_vell=0.1']}")
    with pytest.raises(ConfigError, match=r"variants\[0\] \(a\).*desired_linear_vell"):
        run_campaign(write(tmp_path, bad_set), out, workers=1, progress=False)
    bad_gen = BASE.replace("doors: 0", "dors: 0")
    with pytest.raises(ConfigError, match=r"worlds\[0\].*did you mean 'doors'"):
        run_campaign(write(tmp_path, bad_gen), out, workers=1, progress=False)
    fixed_in_wall = BASE + "routes: {kind: fixed, start: [0, 0, 0], goal: [20, 0, 0]}\n"
    with pytest.raises(ConfigError, match="0 runs to do .*1 route\\(s\\) infeasible"):
        run_campaign(write(tmp_path, fixed_in_wall), out, workers=1, progress=False)
    assert not list(out.glob("runs/*"))
