"""navlog ci run SUITE.yaml: replay golden logs, diff against baselines, check invariants, report."""

from __future__ import annotations

import argparse
from typing import Any

from navlog.commands import add_force, refuse_existing


def register(sub: Any) -> None:
    p = sub.add_parser(
        "ci",
        help="replay-and-diff gate: run a suite of golden logs against committed baselines",
        description="Run a suite (YAML): per case, record the golden log from its recipe (or read the log), "
        "check it for what the pipeline reads, replay it (cached by log hash, parameter hash and navlog "
        "version), diff the outputs against the case's baseline with tolerances, and evaluate its invariants. "
        "Statuses: PASS, IMPROVED, NEW, FAIL, NONDETERMINISTIC, INVALID_INPUT, ERROR. Exit 0 when every case "
        "passes, 1 on a regression (FAIL or NEW), 2 on bad input (INVALID_INPUT, ERROR, a bad suite or option), "
        "3 when a replay is not deterministic.",
        epilog="examples:\n  navlog ci run config/suites/navlog.yaml\n"
        "  navlog ci run suite.yaml --update-new                       # write the missing baselines\n"
        "  navlog ci run suite.yaml --set global_costmap.inflation_layer.inflation_radius=0.35\n"
        "  navlog ci run suite.yaml --workers 2 --determinism --json ci.json --junit ci.xml --markdown ci.md",
    )
    actions = p.add_subparsers(dest="ci_action", metavar="ACTION", required=True)
    run_p = actions.add_parser("run", help="run a suite", description=p.description, epilog=p.epilog)
    run_p.add_argument("suite", help="the suite YAML file")
    mode = run_p.add_mutually_exclusive_group()
    mode.add_argument("--update", action="store_true", help="rewrite every case's baseline")
    mode.add_argument(
        "--update-new", action="store_true", help="write the baselines that are missing or from another navlog version"
    )
    run_p.add_argument("--determinism", action="store_true", help="replay every case twice afresh and compare bytes")
    run_p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a parameter override for every case whose pipeline has KEY (repeatable); the report names the "
        "cases it was not applied to",
    )
    run_p.add_argument("--workers", type=int, default=1, metavar="N", help="cases in parallel (processes; default 1)")
    run_p.add_argument(
        "--cache", metavar="DIR", help="the cache folder (default $NAVLOG_CACHE/ci or ~/.cache/navlog/ci)"
    )
    run_p.add_argument(
        "--baselines",
        metavar="DIR",
        help="the baselines folder (default: the suite's `baselines`, else data/baselines beside the suite file)",
    )
    run_p.add_argument("--json", metavar="FILE", help="write the result as JSON (same results, same bytes)")
    run_p.add_argument("--junit", metavar="FILE", help="write JUnit XML (a test suite per case, a test per check)")
    run_p.add_argument(
        "--markdown", metavar="FILE", help="write Markdown for a pull request (also appended to $GITHUB_STEP_SUMMARY)"
    )
    run_p.add_argument(
        "--case",
        action="append",
        default=[],
        metavar="NAME",
        help="run only this case (repeatable); a --set key it lacks is then an error",
    )
    add_force(run_p, "overwrite existing --json, --junit and --markdown files")
    run_p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from navlog.analysis.ci.reports import format_result, write_reports
    from navlog.analysis.ci.runner import run_suite
    from navlog.campaign import run_campaign_case
    from navlog.errors import ConfigError

    if args.workers < 1:
        raise ConfigError(f"--workers {args.workers}: expected 1 or more")
    refuse_existing(args.force, args.json, args.junit, args.markdown)
    result = run_suite(
        args.suite,
        update=args.update,
        update_new=args.update_new,
        determinism=args.determinism,
        overrides=args.set,
        workers=args.workers,
        cache_dir=args.cache,
        baseline_dir=args.baselines,
        cases=args.case,
        campaign_runner=run_campaign_case,
    )
    print(format_result(result))
    for path in write_reports(result, json_path=args.json, junit_path=args.junit, markdown_path=args.markdown):
        print(f"Wrote {path}")
    return result.exit_code
