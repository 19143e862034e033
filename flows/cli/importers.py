"""`rescene import FORMAT SRC OUT.zarr`: bring ScanNet scenes, RGB-D folders, nerfstudio folders and
panoptic outputs into the capture format (docs/importing.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _cmd_import(args: argparse.Namespace) -> int:
    from rescene_core.capture.importers import FORMATS, ImportInputError, ImportOptions, import_capture, report_path

    if args.format not in FORMATS:
        print(f"unknown format {args.format!r}; formats: {', '.join(FORMATS)}", file=sys.stderr)
        return 2
    fields = {
        "scene_id": args.scene_id,
        "stride": args.stride,
        "max_frames": args.max_frames,
        "depth_scale": args.depth_scale,
        "pose_convention": args.pose_convention,
        "camera_axes": args.camera_axes,
        "align": args.align,
        "segment": args.segment,
        "clip_model": str(args.clip_model) if args.clip_model else None,
        "resolution": args.resolution,
        "overwrite": args.overwrite,
    }
    if args.up is not None:
        try:
            up = tuple(float(v) for v in args.up.split(","))
        except ValueError:
            up = ()
        if len(up) != 3:
            print(
                f"error: --up {args.up!r}: give the source's up as three numbers x,y,z (e.g. --up 0,1,0)",
                file=sys.stderr,
            )
            return 2
        fields["up"] = up
    if args.max_tilt is not None:
        if not 0.0 < args.max_tilt <= 180.0:
            print(
                f"error: --max-tilt {args.max_tilt:g}: give an angle in degrees, above 0 and at most 180",
                file=sys.stderr,
            )
            return 2
        fields["max_tilt"] = args.max_tilt
    if args.vocabulary:
        fields["vocabulary"] = tuple(v.strip() for v in args.vocabulary.split(",") if v.strip())
    extra = {}
    if args.masks is not None:  # the panoptic format's instance PNGs, or a 2D segmenter's for --segment masks
        extra["masks" if args.format == "panoptic" else "mask_dir"] = args.masks
    if args.labels is not None:
        extra["labels"] = args.labels
    if args.base is not None:
        extra["base"] = args.base
    try:
        opts = ImportOptions(**{k: v for k, v in fields.items() if v is not None})
        report = import_capture(args.format, args.src, args.out, opts, **extra)
    except ImportInputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except FileExistsError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except TypeError as err:  # an option the format does not take
        print(f"error: {args.format}: {err}", file=sys.stderr)
        return 2
    f, inst, al = report["frames"], report["instances"], report["alignment"]
    print(
        f"imported {report['src']} ({report['format']}) -> {report['out']}: {f['kept']} of {f['in_source']} frames "
        f"({f['dropped']} dropped{': ' + str(f['dropped_by_reason']) if f['dropped'] else ''}), "
        f"{inst['objects']} objects + {inst['structural']} structural instances by {report['segmenter']}, "
        f"depth coverage {report['depth'].get('coverage_mean', 0):.0%}"
    )
    prior = (
        f", {al['floor_to_prior_up_deg']:.2f} deg from the given up ({al['gravity_from']})"
        if al["gravity_from"]
        else ""
    )
    fallback = " (FALLBACK: no floor found; see the WARNING)" if al["method"] == "cameras" else ""
    print(
        f"alignment: {al['method']}{fallback}, floor normal {al['floor_to_camera_up_deg']:.2f} deg from the cameras' up{prior}, "
        f"{report['throughput_fps']:.2f} frames/s"
    )
    for note in report["notes"]:
        print(f"note: {note}")
    print(f"report: {report_path(args.out)}")
    for warning in report.get("warnings", []):
        _shout(warning)
    if args.pictures:
        from rescene_core.capture.importers.pictures import write_pictures

        for what, path in write_pictures(args.out).items():
            print(f"picture ({what.replace('_', ' ')}): {path}")
    return 0


def _shout(text: str) -> None:
    """A warning the user must not miss, framed, on stderr."""
    bar = "!" * 100
    sys.stdout.flush()
    print(f"{bar}\nWARNING: {text}\n{bar}", file=sys.stderr, flush=True)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("import", help="import a ScanNet scene, an RGB-D folder, a nerfstudio folder or panoptic output")
    p.add_argument("format", help="scannet | rgbd | nerfstudio | panoptic")
    p.add_argument("src", type=Path, help="the source folder")
    p.add_argument("out", type=Path, help="output capture, e.g. room.zarr")
    p.add_argument(
        "--segment",
        choices=["none", "geometric", "masks"],
        help="geometric: label-free instances (TSDF + planes + superpoints merged by geometry and colour); "
        "masks: superpoints merged by the view consensus of a 2D segmenter's per-frame masks (--masks DIR)",
    )
    p.add_argument("--clip-model", type=Path, help="local open_clip checkpoint to label geometric segments zero-shot")
    p.add_argument("--vocabulary", help="comma-separated labels for --clip-model")
    p.add_argument("--stride", type=int, help="keep every n-th frame")
    p.add_argument("--max-frames", type=int, help="keep at most this many frames")
    p.add_argument("--depth-scale", type=float, help="metres per depth unit (default 0.001: millimetres)")
    p.add_argument("--pose-convention", choices=["cam_to_world", "world_to_cam"])
    p.add_argument("--camera-axes", choices=["opencv", "opengl"])
    p.add_argument("--align", choices=["floor", "none"], help="floor (default): z up, floor at z = 0")
    p.add_argument(
        "--up",
        metavar="X,Y,Z",
        help="the recorder's up (minus its gravity) in the source's world frame, e.g. 0,1,0 for a y-up headset; "
        "refined by the floor plane near it (default: SRC/gravity.txt when there, else a floor search)",
    )
    p.add_argument(
        "--max-tilt",
        type=float,
        metavar="DEG",
        help="largest angle between the floor normal and the prior up (default 10 with --up, 80 from the cameras)",
    )
    p.add_argument("--resolution", choices=["depth", "color"], help="scannet: the image size kept")
    p.add_argument(
        "--masks",
        type=Path,
        help="panoptic: folder of per-frame instance-id PNGs (default SRC/instances); rgbd, nerfstudio with "
        "--segment masks: a 2D segmenter's per-frame id PNGs named like the frames (ids need not agree across frames)",
    )
    p.add_argument(
        "--labels", type=Path, help="panoptic: labels.json (default SRC/labels.json); scannet: label map TSV"
    )
    p.add_argument("--base", choices=["rgbd", "scannet", "nerfstudio"], help="panoptic: the layout of the frames")
    p.add_argument("--scene-id", help="name of the scene (default: the source folder's name)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing capture")
    p.add_argument("--pictures", action="store_true", help="also write the segments over frames and a plan")
    p.set_defaults(func=_cmd_import)
