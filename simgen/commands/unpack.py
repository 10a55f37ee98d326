"""`simgen unpack`: a dataset back from `simgen pack`'s compact copy."""

from __future__ import annotations

from pathlib import Path

from simgen.commands.arguments import add_command
from simgen.output_path import check_output


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "unpack",
        "a dataset back from `simgen pack`'s compact copy",
        "Write the dataset packed in PACKED into OUT: the points as float32 metres in the reader's "
        "layout, the other files as they were (each checked against its sha256), and a manifest with "
        "the new files' sizes and sha256, so OUT opens and verifies like any dataset. Needs neither the "
        "football engine nor Embree (`python -m simgen.cli unpack` on a bare training machine). OUT must "
        "not exist; an interrupted or failed run leaves none.",
    )
    parser.add_argument("packed", type=Path, metavar="PACKED", help="folder that `simgen pack` wrote")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT", help="dataset folder to create")
    parser.set_defaults(func=run)


def run(args) -> int:
    from simgen.datasets.compact import unpack

    check_output(args.output, "folder", reads=[args.packed], new=True)
    manifest = unpack(args.packed, args.output, progress=True)
    print(f"{args.output}: {manifest.format} dataset, {len(manifest.files)} files, unpacked from {args.packed}")
    return 0
