"""navlog campaign run: one or more Nav2 variants across generated or given worlds, seeds and routes."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "campaign",
        help="run a navigation campaign: Nav2 variants across many worlds and seeds, with statistics",
        description="Run every world x robot x seed x route x variant of a campaign file as an isolated recording, "
        "on this machine's cores or Ray, and report per variant the success rate (Wilson interval), the BARN "
        "metric, times and paths (bootstrap intervals), and each variant against the baseline (exact McNemar, "
        "Wilcoxon) with a verdict; the controller's cycle time per run (wall clock, apart from the deterministic "
        "reports) and a contact sheet of the runs that did not succeed. A rerun into the same folder reuses every "
        "finished run.",
        epilog="example:\n  navlog campaign run campaign.yaml -o out/ --workers 2\n"
        "  navlog campaign run campaign.yaml -o out/ --keep-logs failed",
    )
    actions = p.add_subparsers(dest="campaign_action", metavar="ACTION", required=True)
    run_p = actions.add_parser(
        "run", help="run a campaign file into a folder", description="Run a campaign file (see the campaigns guide)."
    )
    run_p.add_argument("campaign", type=Path, help="the campaign YAML")
    run_p.add_argument("-o", "--output", type=Path, required=True, help="output folder (reused runs are kept)")
    run_p.add_argument("--workers", type=int, help="worker processes (default: the usable CPUs; 1: this process)")
    run_p.add_argument(
        "--ray",
        nargs="?",
        const=True,
        default=None,
        metavar="ADDRESS",
        help="run on Ray (a local instance, or ADDRESS)",
    )
    run_p.add_argument(
        "--keep-logs",
        nargs="?",
        const="all",
        default="none",
        choices=("all", "failed", "none"),
        help="keep each run's MCAP in OUT/logs (all, or only the runs that did not succeed)",
    )
    run_p.add_argument("--variant", action="append", default=[], help="run only this variant (repeatable)")
    run_p.set_defaults(func=run)


def run(args) -> int:
    from navlog.campaign.runner import run_campaign

    res = run_campaign(
        args.campaign,
        args.output,
        workers=args.workers,
        ray=args.ray,
        keep_logs=args.keep_logs,
        progress=not args.quiet,
        only=args.variant,
    )
    print((args.output / "campaign.md").read_text(), end="")
    timing = (args.output / "campaign_timing.md").read_text().split("\n\n", 1)[1]  # without its title
    print("\n## Controller cycle time (wall clock, this machine)\n\n" + timing, end="")
    runs = sum(r["result"] != "infeasible" for r in res.rows)
    print(f"\n{runs} runs ({res.cached} reused) in {res.wall_s:.1f} s; wrote " + ", ".join(str(f) for f in res.files))
    failed = sum(r["result"] == "failed" for r in res.rows)
    return 1 if failed else 0
