"""navlog recover: salvage the complete chunks of a truncated MCAP file."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "recover",
        help="salvage a truncated MCAP file (e.g. after kill -9) into a valid one",
        description="Copy every complete chunk of a truncated MCAP file (schemas, channels, metadata, "
        "messages) into a new, finished file, and report how many messages and seconds were kept.",
        epilog="example:\n  navlog recover run.mcap.part -o run-fixed.mcap",
    )
    p.add_argument("broken", type=Path, help="the truncated .mcap (or .mcap.part) file")
    p.add_argument("-o", "--output", required=True, type=Path, help="the repaired .mcap file to write")
    p.add_argument("--force", action="store_true", help="overwrite the output if it exists")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.replay.io.recovery import recover_mcap

    res = recover_mcap(args.broken, args.output, force=args.force)
    state = "the input was complete" if res.complete else "the input was truncated"
    print(
        f"wrote {args.output}: kept {res.messages} messages, {res.seconds:.2f} s of log "
        f"({state}; read {res.bytes_read / 1e6:.1f} of {res.bytes_total / 1e6:.1f} MB)"
    )
    for why, count in sorted(res.chunks_skipped.items()):
        print(f"left out {count} damaged chunk(s): {why}")
    if res.metadata_lost:
        print(
            "metadata lost: navlog writes its metadata record (world, robot, scenario, seed) when it finishes a "
            "file, and this one was cut before; the messages are kept, `navlog info` will not show them"
        )
    return 0
