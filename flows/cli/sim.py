"""`rescene simcheck RUN [--shake] [--engine mujoco|newton]` (the physics check) and `rescene export RUN` (the scene exports again)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _cmd_simcheck(args: argparse.Namespace) -> int:
    from rescene_core.sim import SimcheckConfig, simcheck_run

    config = SimcheckConfig(seconds=args.seconds, shake=args.shake, seed=args.seed)
    if args.engine == "newton":
        return _newton(args, config)
    try:
        result = simcheck_run(args.run, config)
    except RuntimeError as err:  # the simulation diverged
        print(f"error: {err}", file=sys.stderr)
        return 1
    s = result.summary
    print(
        f"{s.stable}/{s.free} free objects stable after {s.seconds_simulated} s"
        f"{' with shake' if s.shake else ''} (stable fraction {s.stable_fraction:.3f}); "
        f"{s.fixed} mounted; fell through {s.fell_through}, escaped {s.escaped}"
    )
    print(
        f"penetration at t=0: max {s.penetration_t0_max * 1000:.1f} mm, mean {s.penetration_t0_mean * 1000:.2f} mm"
        + (f" ({' / '.join(result.deepest_pair)})" if result.deepest_pair and s.penetration_t0_max > 0 else "")
    )
    for o in result.objects:
        if o.kind == "free" and not o.stable:
            flags = ", fell through" if o.fell_through else ", escaped" if o.escaped else ""
            print(f"  unstable {o.node}: moved {o.translation * 100:.1f} cm, turned {o.rotation_deg:.1f} deg{flags}")
    print(f"wrote {Path(args.run) / 'sim/simcheck.json'} and {Path(args.run) / 'sim/before_after.png'}")
    return 0


def _newton(args: argparse.Namespace, config) -> int:
    from rescene_core.paths import RunPaths
    from rescene_core.sim.newton_check import newton_simcheck_run

    try:
        record = newton_simcheck_run(args.run, config)
    except (RuntimeError, FileNotFoundError) as err:  # Newton missing, no USD, or the simulation diverged
        print(f"error: {err}", file=sys.stderr)
        return 1
    s = record["summary"]
    print(
        f"Newton ({record['config']['solver']}, step {record['config']['timestep'] * 1000:g} ms): "
        f"{s['stable']}/{s['free']} free objects stable after {s['seconds_simulated']} s"
        f"{' with shake' if s['shake'] else ''} (stable fraction {s['stable_fraction']:.3f}); {s['fixed']} fixed; "
        f"fell through {s['fell_through']}, escaped {s['escaped']}; penetration at t=0 max "
        f"{s['penetration_t0_max'] * 1000:.1f} mm"
    )
    for o in record["objects"]:
        if o["kind"] == "free" and not o["stable"]:
            print(f"  unstable {o['node']}: moved {o['translation'] * 100:.1f} cm, turned {o['rotation_deg']:.1f} deg")
    if "disagreements" in record:
        print(f"MuJoCo and Newton disagree on {len(record['disagreements'])} objects")
        for d in record["disagreements"]:
            print(
                f"  {d['node']}: stable in {'MuJoCo' if d['stable_mujoco'] else 'Newton'} only "
                f"(drift {d['drift_mujoco'] * 100:.1f} cm vs {d['drift_newton'] * 100:.1f} cm): {'; '.join(d['reasons'])}"
            )
    else:
        print("no MuJoCo check with the same shake setting to compare with (`rescene simcheck RUN` writes one)")
    print(f"wrote {RunPaths(args.run).simcheck_newton}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from rescene_core.export import ExportConfig
    from rescene_core.export.scene import export_run

    hashes = export_run(args.run, ExportConfig(usd_binary=args.usdc))
    print(
        f"wrote {len(hashes)} files under {Path(args.run) / 'scene'}: "
        + ", ".join(sorted(h for h in hashes if "/" not in h or h.startswith("mjcf/")))
    )
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simcheck", help="physics check of a run's MJCF: penetration, drift under gravity")
    p.add_argument("run", type=Path, help="run directory with scene/mjcf/scene.xml")
    p.add_argument("--shake", action="store_true", help="shake the room horizontally during the first second")
    p.add_argument("--seed", type=int, default=0, help="seed of the shake")
    p.add_argument("--seconds", type=float, default=2.0, help="simulated time (s)")
    p.add_argument(
        "--engine",
        choices=("mujoco", "newton"),
        default="mujoco",
        help="mujoco: scene/mjcf/scene.xml -> sim/simcheck.json (default); newton: scene/scene.usda through "
        "Newton's USD importer -> sim/simcheck-newton.json, compared with the MuJoCo check (the `newton` extra)",
    )
    p.set_defaults(func=_cmd_simcheck)

    p = sub.add_parser("export", help="write a run's scene exports again (GLB, MJCF, USD, export report)")
    p.add_argument("run", type=Path, help="run directory with scene/scene.json")
    p.add_argument("--usdc", action="store_true", help="binary USD (scene.usdc) instead of scene.usda")
    p.set_defaults(func=_cmd_export)
