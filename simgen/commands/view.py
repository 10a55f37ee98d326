"""`simgen view`: bird's-eye and side views of a clip's frames as PNGs and an MP4; frames as PCD or PLY;
the clip as a Rerun recording."""

from __future__ import annotations

import time
from pathlib import Path

from simgen.commands.arguments import add_command, add_dataset_argument, frame_range
from simgen.errors import UserError
from simgen.output_path import check_output

DEFAULT_PX_PER_M = 10.0


def register(subparsers) -> None:
    from simgen.view import COLOURINGS, EXPORT_FORMATS

    parser = add_command(
        subparsers,
        "view",
        "pictures of a clip: bird's-eye and side views (PNG, MP4); frames as PCD or PLY",
        "Draw the frames A:B of a clip: a bird's-eye view of the pitch (points coloured by height or "
        "intensity, the painted lines, each box with its track id and a heading arrow, grey when no "
        "point hit it; the sensors and their heads' boresights) above a side view (looking along +y, "
        "height stretched x4). Writes OUT/<clip>/frame_NNNNNN.png per frame and OUT/<clip>.mp4 "
        "(H.264, plays in browsers, at the clip's frame rate). --export-frame writes frames' points as "
        "OUT/<clip>/frame_NNNNNN.pcd or .ply (x, y, z in the pitch frame, metres, and intensity) "
        "for CloudCompare or Open3D's viewer. --rerun FILE.rrd writes the same frames as a Rerun "
        "recording (3D points coloured as above, boxes with track ids and headings, each head's field of "
        "view, on a game-time timeline), with or without -o.",
    )
    add_dataset_argument(parser)
    parser.add_argument(
        "-o", "--output", type=Path, metavar="OUT", help="output directory (created) for PNGs, MP4 and exports"
    )
    parser.add_argument(
        "--rerun",
        type=Path,
        metavar="FILE.rrd",
        help="also (or, without -o, only) write the frames as a Rerun recording: points, boxes with track "
        "ids and headings, sensor frusta, on a game-time timeline; open it with `rerun FILE.rrd`",
    )
    parser.add_argument(
        "--tracks",
        type=Path,
        metavar="TRACK_OUT",
        help="the paper's Fig. 6 instead of the frames: the labelled trajectories beside those `simgen-train track` "
        "wrote to TRACK_OUT (its tracks.parquet) over the pitch, one colour per id, identity switches ringed in red; "
        "writes OUT/<clip>_tracks.png (the window A:B) and OUT/<clip>_tracks.mp4 (drawn frame by frame, H.264)",
    )
    parser.add_argument("--clip", help="clip id (default: the first clip)")
    parser.add_argument(
        "--frames", default=":", metavar="A:B", help="frames A to B-1 (Python slice; default all), or one frame A"
    )
    parser.add_argument(
        "--colour", choices=COLOURINGS, default="height", help="colour points by height or intensity (default height)"
    )
    parser.add_argument("--scale", type=float, default=DEFAULT_PX_PER_M, metavar="PX_PER_M",
                        help=f"pixels per metre (default {DEFAULT_PX_PER_M:g})")
    parser.add_argument("--export-frame", action="append", default=[], metavar="I|A:B",
                        help="also write frame I's points, or frames A to B-1's, a file per frame, as PCD or PLY "
                        "(repeatable)")
    parser.add_argument(
        "--export-format", choices=EXPORT_FORMATS, default="pcd", help="format of --export-frame (default pcd)"
    )
    parser.add_argument(
        "--no-images", action="store_true", help="write no PNG or MP4 (with --export-frame: only the exports)"
    )
    parser.set_defaults(func=run)


def run(args) -> int:
    if not 1.0 <= args.scale <= 100.0:
        raise UserError(f"--scale must be in 1-100 pixels per metre, got {args.scale:g}")
    if args.output is None and args.rerun is None:
        raise UserError("nothing to write: give -o OUT (pictures, exports) or --rerun FILE.rrd")
    if args.output is None and (args.export_frame or args.no_images):
        raise UserError("--export-frame and --no-images need -o OUT")
    if args.rerun is not None and (args.rerun.suffix != ".rrd" or args.rerun.is_dir()):
        raise UserError(f"--rerun {args.rerun}: expected a file name ending in .rrd")
    if args.rerun is not None:
        check_output(args.rerun, "file", reads=[args.dataset])
    if args.output is not None:
        check_output(args.output, "folder", reads=[args.dataset])
    if args.tracks is not None and (args.output is None or args.export_frame or args.no_images or args.rerun):
        raise UserError("--tracks draws trajectories into -o OUT, alone: without --rerun, --export-frame, --no-images")
    if args.no_images and not args.export_frame:
        raise UserError("--no-images leaves nothing to write: add --export-frame I")
    from simgen.datasets import open_dataset  # the heavy imports after the arguments are checked
    from simgen.qa.checks import plural
    from simgen.view.export import export_frame
    from simgen.view.output import write_clip_view

    started = time.perf_counter()
    dataset = open_dataset(args.dataset)
    clip = args.clip if args.clip is not None else dataset.clips[0]
    frames = frame_range(args.frames, dataset.num_frames(clip))
    exports = sorted({i for text in args.export_frame for i in frame_range(text, dataset.num_frames(clip),
                                                                            "--export-frame")})
    dataset.frame(clip, frames.start)  # a clip that does not read is one line, before any progress bar
    out = args.output
    if args.tracks is not None:
        from simgen.view.trajectories import write_trajectory_view

        out.mkdir(parents=True, exist_ok=True)
        png, video, switches = write_trajectory_view(dataset, clip, frames, args.tracks / "tracks.parquet", out,
                                                     args.scale)
        print(f"{png}: labelled and tracked trajectories of {clip}, frames {frames.start}-{frames.stop - 1}, "
              f"{switches} ID switch{'' if switches == 1 else 'es'}")
        print(f"{video}: drawn frame by frame at {dataset.manifest.sensors[0].frame_rate_hz:g} fps (H.264)")
        print(f"done in {time.perf_counter() - started:.1f} s")
        return 0
    if args.rerun is not None:
        from simgen.view.rerun_view import write_recording

        written = write_recording(dataset, clip, frames, args.rerun, args.colour)
        print(f"{args.rerun}: {plural(written, 'frame')} of {clip} (Rerun; open with `rerun {args.rerun}`)")
    if out is None:
        print(f"done in {time.perf_counter() - started:.1f} s")
        return 0
    out.mkdir(parents=True, exist_ok=True)
    if not args.no_images:
        view = write_clip_view(dataset, clip, frames, out, args.colour, args.scale)
        last = f" ... frame_{frames.stop - 1:06d}.png" if len(frames) > 1 else ""
        print(f"{out / clip}/: {plural(view.frames, 'PNG')} frame_{frames.start:06d}.png{last} "
              f"({view.size_px[0]} x {view.size_px[1]} px)")
        print(
            f"{view.video}: {plural(view.frames, 'frame')} at {dataset.manifest.sensors[0].frame_rate_hz:g} fps "
            f"(H.264)"
        )
    for index in exports:
        path = out / clip / f"frame_{index:06d}.{args.export_format}"
        path.parent.mkdir(parents=True, exist_ok=True)
        frame = dataset.frame(clip, index)
        export_frame(frame, path)
        print(f"{path}: {len(frame.points_m):,} points (x, y, z pitch frame, intensity)")
    print(f"done in {time.perf_counter() - started:.1f} s")
    return 0
