"""The pytest plugin: a *.navlog-suite.yaml file's cases as tests, failures listing every check."""

from __future__ import annotations

from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

pytest_plugins = ["pytester"]


def plugin_opts() -> list[str]:
    """Load the plugin by name only where the installed entry point (pytest11 "navlog") does not."""
    from importlib.metadata import entry_points

    installed = any(ep.value == "navlog.analysis.ci.pytest_plugin" for ep in entry_points(group="pytest11"))
    return ["--navlog-suites"] + ([] if installed else ["-p", "navlog.analysis.ci.pytest_plugin"])


SUITE = """\
cases:
  - name: wall
    pipeline: safety
    recipe: {world: walled_room, robot: kibot, scenario: teleop_wall}
    remap: {/cmd_vel_nav: /cmd_vel}
    checks: [{diff: {}}, safety.commands_in == 301]
  - name: wall_no_collision
    pipeline: safety
    recipe: {world: walled_room, robot: kibot, scenario: teleop_wall}
    remap: {/cmd_vel_nav: /cmd_vel}
    checks: [no_collision]
"""


def test_suite_file_cases_are_tests(pytester: pytest.Pytester, ci_cache: Path):
    pytester.makefile(".navlog-suite.yaml", wall=SUITE)
    cache = str(ci_cache)
    opts = [*plugin_opts(), "--navlog-cache", cache, "--navlog-baselines", "b"]
    result = pytester.runpytest_subprocess(*opts)
    # no baseline yet: NEW fails; the recorded run hit the wall, so no_collision fails
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(["*NEW: case wall (safety*", "*FAIL*invariant no_collision: no_collision is False*"])
    result = pytester.runpytest_subprocess(
        *opts, "--navlog-update-new", "-k", "wall and not no_collision", "--junitxml", "r.xml"
    )
    result.assert_outcomes(passed=1)
    assert 'name="safety.commands_in" value="301.0"' in (pytester.path / "r.xml").read_text()


def test_bad_suite_is_a_collection_error(pytester: pytest.Pytester):
    pytester.makefile(".navlog-suite.yaml", bad="cases:\n  - {name: a, pipline: mapping, log: x.mcap}\n")
    result = pytester.runpytest_subprocess(*plugin_opts())
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*pipline: unknown key (did you mean 'pipeline'?)*"])


def test_suite_files_are_collected_only_when_asked_for(pytester: pytest.Pytester):
    """A plain pytest run never reads a suite file: an alias bomb named *.navlog-suite.yaml is left alone
    unless --navlog-suites or the ini option asks for suites, and then it is refused, not expanded."""
    bomb = 'l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n' + "".join(
        f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]\n" for i in range(1, 9)
    )
    pytester.makefile(".navlog-suite.yaml", bomb=bomb)
    pytester.makepyfile(test_other="def test_one():\n    assert True\n")
    opts = [o for o in plugin_opts() if o != "--navlog-suites"]
    pytester.runpytest_subprocess(*opts).assert_outcomes(passed=1)
    pytester.makeini("[pytest]\nnavlog_suites = true\n")
    result = pytester.runpytest_subprocess(*opts)
    result.assert_outcomes(errors=1)  # a collection error stops the session before any test runs
    result.stdout.fnmatch_lines(["*more than 200,000 values once its aliases are expanded*"])


def test_cases_run_the_same_under_pytest_xdist(pytester: pytest.Pytester, ci_cache: Path):
    """`pytest -n 2`: each worker runs its cases alone; the outcomes are those of a serial run."""
    pytest.importorskip("xdist")
    pytester.makefile(".navlog-suite.yaml", wall=SUITE)
    result = pytester.runpytest_subprocess(
        *plugin_opts(), "-n", "2", "--navlog-cache", str(ci_cache), "--navlog-baselines", "b"
    )
    result.assert_outcomes(failed=2)
    result.stdout.fnmatch_lines(["*created: 2/2 workers*"])
    for line in ("*NEW: case wall (safety*", "*FAIL*invariant no_collision: no_collision is False*"):
        result.stdout.fnmatch_lines([line])  # the workers finish in either order
