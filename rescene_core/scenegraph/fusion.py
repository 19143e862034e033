"""Multi-frame fusion: per-frame answers + geometric, category and room-shell priors -> one scene graph.

For each candidate edge k = (c_k, r_k, p_k) into a child (paper Eq. 2 and Appendix "Multi-Frame Fusion
Details"):

    S_k = alpha V_k + beta G_k + gamma Phi_k                                   (no room shell)
    S_k = (1 - w_s)(alpha V_k + beta G_k + gamma Phi_k) + w_s Shell_k          (room shell available)

V_k: fraction of the usable frames showing c_k whose answer is (r_k, p_k). G_k, Shell_k: ``priors``.
Phi_k: ``category``. Candidates: rests-on floor, mounts-on wall, every edge some frame proposed, and every
object whose upward face supports the child geometrically. Missing instances (asset generation or
registration failed) get no edge but stay candidate parents: a child whose best candidate is one keeps
that dangling edge, flagged 'parent-missing', rather than a floor or wall edge its evidence contradicts. The argmax is kept with omega = S; it is
'uncertain' when the top-2 margin < uncertain_margin or S < uncertain_top, and 'low-confidence' below
low_confidence. Uncertain edges are re-asked with an A/B prompt (backends that support it) and a changed
answer is kept only if its G is not below the other candidate's by more than ab_geometry_margin. Cycles
are broken by dropping the weakest edge on the cycle and re-choosing that child's next candidate.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import networkx as nx
import numpy as np

from rescene_core.capture import Capture
from rescene_core.config import SceneGraphConfig
from rescene_core.records import Edge, InstanceId, Parent, Relation, RoomShell, Root, SceneGraph, parent_to_json
from rescene_core.scenegraph.backend import Query, RelationPredictor, TransportError
from rescene_core.scenegraph.category import CategoryPrior, load_prior
from rescene_core.scenegraph.frame import FramePrediction
from rescene_core.scenegraph.geom import floor_only_shell
from rescene_core.scenegraph.overlay import overlay_ids, png_bytes
from rescene_core.scenegraph.priors import (
    InstanceGeometry,
    geometric_prior,
    instance_geometry,
    object_support,
    shell_prior,
    wall_alignment,
)
from rescene_core.scenegraph.prompt import AB_SCHEMA, SYSTEM_PROMPT, ab_prompt
from rescene_core.scenegraph.view import frame_view

Candidate = tuple[Relation, Parent]
ROOT_CANDIDATES: tuple[Candidate, ...] = ((Relation.RESTS_ON, Root.FLOOR), (Relation.MOUNTS_ON, Root.WALL))


@dataclass
class FusionReport:
    """Everything fusion decided: candidate scores per child, uncertain and low-confidence edges,
    A/B re-ranking calls, cycles broken, the weights and the category prior used."""

    variant: str
    weights: dict[str, float]
    shell_prior: bool
    prior_provenance: str
    candidates: dict[int, list[dict[str, Any]]] = field(default_factory=dict)
    uncertain: list[int] = field(default_factory=list)
    low_confidence: list[int] = field(default_factory=list)
    unobserved: list[int] = field(default_factory=list)
    parent_missing: list[int] = field(default_factory=list)
    ab: list[dict[str, Any]] = field(default_factory=list)
    cycles_broken: list[dict[str, Any]] = field(default_factory=list)
    frames_used: int = 0
    frames_failed: int = 0
    seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "variant": self.variant,
            "weights": self.weights,
            "shell_prior": self.shell_prior,
            "prior_provenance": self.prior_provenance,
            "frames_used": self.frames_used,
            "frames_failed": self.frames_failed,
            "uncertain": self.uncertain,
            "low_confidence": self.low_confidence,
            "unobserved": self.unobserved,
            "parent_missing": self.parent_missing,
            "ab": self.ab,
            "cycles_broken": self.cycles_broken,
            "candidates": {str(k): v for k, v in self.candidates.items()},
            "seconds": round(self.seconds, 4),
        }


def _key(c: Candidate) -> tuple:
    rel, parent = c
    return (0, parent.value, rel.value) if isinstance(parent, Root) else (1, int(parent), rel.value)


def _weights(config: SceneGraphConfig, with_shell: bool) -> dict[str, float]:
    scale = 1.0 - config.fusion.shell_weight if with_shell else 1.0
    return {
        "V": config.fusion.alpha * scale,
        "G": config.fusion.beta * scale,
        "Phi": config.fusion.gamma * scale,
        "shell": config.fusion.shell_weight if with_shell else 0.0,
    }


def _proposals(child: InstanceGeometry, geometry: dict[InstanceId, InstanceGeometry], config) -> list[InstanceId]:
    """Objects whose upward faces could hold ``child`` (cheap bounding-box test, then the support prior)."""
    out: list[InstanceId] = []
    if child.empty:
        return out
    lo, hi = child.points[:, :2].min(axis=0), child.points[:, :2].max(axis=0)
    for iid, g in geometry.items():
        if iid == child.instance or g.empty:
            continue
        glo, ghi = g.points[:, :2].min(axis=0), g.points[:, :2].max(axis=0)
        if (glo > hi + config.geometric.support_radius).any() or (ghi < lo - config.geometric.support_radius).any():
            continue
        if object_support(child, g, config) >= config.geometric.min_support_overlap:
            out.append(iid)
    return out


def _shown(parent: Parent, to_display: dict[InstanceId, int]) -> int | str | None:
    """A parent as the frame shows it: a root name, a display id, or None when not visible there."""
    return parent.value if isinstance(parent, Root) else to_display.get(InstanceId(int(parent)))


def _ab_recheck(
    child: InstanceId,
    ranked: list[dict[str, Any]],
    predictions: list[FramePrediction],
    capture: Capture,
    shell: RoomShell | None,
    config: SceneGraphConfig,
    predictor: RelationPredictor,
    report: FusionReport,
) -> int:
    """Re-ask high-visibility frames which of the top two candidates holds; index of the kept candidate."""
    a, b = ranked[0], ranked[1]
    frames = sorted(
        (p for p in predictions if p.usable and any(v.instance == child for v in p.visible)),
        key=lambda p: -next(v.pixels for v in p.visible if v.instance == child),
    )
    votes = {"A": 0, "B": 0}
    calls: list[dict[str, Any]] = []
    for pred in frames:
        if len(calls) >= config.fusion.ab_frames:
            break
        to_display = {v.instance: v.display for v in pred.visible}

        pa, pb = (_shown(a["candidate"][1], to_display), _shown(b["candidate"][1], to_display))
        if pa is None or pb is None:
            continue
        view = frame_view(capture, pred.frame, config)
        image, _ = overlay_ids(view, config.overlay_font_px)
        prompt = ab_prompt(
            to_display[child], view.categories, (a["candidate"][0].value, pa), (b["candidate"][0].value, pb)
        )
        query = Query("ab", SYSTEM_PROMPT, prompt, png_bytes(image), AB_SCHEMA, view, capture, shell)
        try:
            raw = predictor.answer(query)
        except TransportError as err:
            calls.append({"frame": pred.frame, "prompt": prompt, "raw": None, "transport_error": str(err)})
            continue
        choice = None
        try:
            choice = json.loads(raw).get("answer")
        except (ValueError, AttributeError):
            choice = None
        if choice in votes:
            votes[choice] += 1
        calls.append({"frame": pred.frame, "prompt": prompt, "raw": raw, "answer": choice})
    pick = 1 if votes["B"] > votes["A"] else 0
    accepted = True
    if pick == 1 and b["G"] < a["G"] - config.fusion.ab_geometry_margin:
        pick, accepted = 0, False
    report.ab.append(
        {
            "child": int(child),
            "A": _cand_json(a["candidate"]),
            "B": _cand_json(b["candidate"]),
            "votes": votes,
            "kept": "B" if pick == 1 else "A",
            "change_rejected_by_geometry": not accepted,
            "calls": calls,
        }
    )
    return pick


def _cand_json(c: Candidate) -> dict[str, Any]:
    return {"relation": c[0].value, "parent": parent_to_json(c[1])}


def fuse_with_report(
    predictions: list[FramePrediction],
    capture: Capture,
    shell: RoomShell | None,
    config: SceneGraphConfig,
    missing: set[int] | frozenset[int] = frozenset(),
    predictor: RelationPredictor | None = None,
    variant: Literal["full", "vote"] = "full",
    prior: CategoryPrior | None = None,
) -> tuple[SceneGraph, FusionReport]:
    """Fuse per-frame predictions into a scene graph over every non-missing object instance.

    variant 'vote' scores candidates by V alone (the multi-frame vote baseline); 'full' is the paper's
    fusion. predictor: used for A/B re-ranking when it supports it. Returns the graph (a forest; every
    non-missing object instance has exactly one parent) and the report.
    """
    start = time.perf_counter()
    with_shell = shell is not None and config.fusion.use_shell_prior and variant == "full"
    shell_used = shell if shell is not None else floor_only_shell(capture)
    prior = prior if prior is not None else load_prior(config.fusion.prior_path)
    weights = _weights(config, with_shell) if variant == "full" else {"V": 1.0, "G": 0.0, "Phi": 0.0, "shell": 0.0}
    report = FusionReport(variant, weights, with_shell, prior.provenance)
    missing = {int(m) for m in missing}
    labels = {int(i.id): i.label for i in capture.object_instances}
    children = [InstanceId(i) for i in sorted(labels) if i not in missing]
    alive = set(children)
    # missing instances get no edge, but they are still in the room: a child standing on one keeps that
    # edge (flag 'parent-missing'), so its evidence is not pushed onto the floor or a wall
    absent = {InstanceId(i) for i in sorted(missing) if i in labels}
    parents = alive | absent

    seen = {c: 0 for c in children}
    votes: dict[InstanceId, dict[Candidate, int]] = {c: {} for c in children}
    for pred in predictions:
        if not pred.usable:
            report.frames_failed += 1
            continue
        report.frames_used += 1
        for v in pred.visible:
            if v.instance not in alive:
                continue
            seen[v.instance] += 1
            got = pred.relations.get(v.instance)
            if got is None:
                continue
            rel, parent = got
            if not isinstance(parent, Root) and (parent not in parents or parent == v.instance):
                continue
            votes[v.instance][(rel, parent)] = votes[v.instance].get((rel, parent), 0) + 1

    geometry: dict[InstanceId, InstanceGeometry] = {}
    if variant == "full":
        geometry = {c: instance_geometry(capture, c, shell_used, config) for c in [*children, *sorted(absent)]}

    ranked_by_child: dict[InstanceId, list[dict[str, Any]]] = {}
    for c in children:
        cands: set[Candidate] = set(ROOT_CANDIDATES) | set(votes[c])
        if variant == "full":
            cands |= {(Relation.RESTS_ON, p) for p in _proposals(geometry[c], geometry, config)}
        rows = []
        for cand in sorted(cands, key=_key):
            rel, parent = cand
            share = votes[c].get(cand, 0) / seen[c] if seen[c] else 0.0
            row: dict[str, Any] = {"candidate": cand, "V": share, "G": 0.0, "Phi": 0.0, "shell": 0.0}
            if variant == "full":
                row["G"] = geometric_prior(geometry[c], parent, geometry, shell_used, config)
                if rel == Relation.MOUNTS_ON and not isinstance(parent, Root):
                    row["G"] = 0.0  # no geometric model of mounting on an object
                plabel = parent.value if isinstance(parent, Root) else labels[int(parent)]
                row["Phi"] = prior.phi(labels[int(c)], rel, plabel)
                if with_shell:
                    row["shell"] = shell_prior(geometry[c], parent, shell_used, config)
            row["S"] = sum(weights[k] * row[k] for k in ("V", "G", "Phi", "shell"))
            rows.append(row)
        rows.sort(key=lambda r: (-r["S"], _key(r["candidate"])))
        ranked_by_child[c] = rows
        if not seen[c]:
            report.unobserved.append(int(c))

    choice: dict[InstanceId, int] = {c: 0 for c in children}
    flags: dict[InstanceId, list[str]] = {c: [] for c in children}
    for c in children:
        rows = ranked_by_child[c]
        top = rows[0]["S"]
        margin = top - rows[1]["S"] if len(rows) > 1 else top
        if margin < config.fusion.uncertain_margin or top < config.fusion.uncertain_top:
            flags[c].append("uncertain")
            if predictor is not None and predictor.supports_ab and variant == "full" and len(rows) > 1:
                pick = _ab_recheck(c, rows, predictions, capture, shell, config, predictor, report)
                flags[c].append("ab-rechecked")
                if pick == 1:
                    flags[c].append("ab-changed")
                    choice[c] = 1
                elif report.ab and report.ab[-1]["change_rejected_by_geometry"]:
                    flags[c].append("ab-rejected-by-geometry")

    banned: dict[InstanceId, set[int]] = {c: set() for c in children}
    while True:
        graph = nx.DiGraph()
        for c in children:
            parent = ranked_by_child[c][choice[c]]["candidate"][1]
            if not isinstance(parent, Root):
                graph.add_edge(c, InstanceId(int(parent)))
        try:
            cycle = nx.find_cycle(graph)
        except nx.NetworkXNoCycle:
            break
        members = [u for u, _ in cycle]
        weakest = min(members, key=lambda u: (ranked_by_child[u][choice[u]]["S"], -int(u)))
        banned[weakest].add(choice[weakest])
        dropped = ranked_by_child[weakest][choice[weakest]]
        # Root candidates are never on a cycle, so one is always left.
        nxt = next(k for k in range(len(ranked_by_child[weakest])) if k not in banned[weakest])
        choice[weakest] = nxt
        flags[weakest].append("cycle-rechosen")
        report.cycles_broken.append(
            {
                "cycle": [int(u) for u in members],
                "child": int(weakest),
                "dropped": _cand_json(dropped["candidate"]),
                "now": _cand_json(ranked_by_child[weakest][nxt]["candidate"]),
            }
        )

    edges = []
    for c in children:
        rows = ranked_by_child[c]
        row = rows[choice[c]]
        rel, parent = row["candidate"]
        others = [r["S"] for k, r in enumerate(rows) if k != choice[c]]
        margin = row["S"] - max(others) if others else row["S"]
        if row["S"] < config.fusion.low_confidence:
            flags[c].append("low-confidence")
            report.low_confidence.append(int(c))
        if "uncertain" in flags[c]:
            report.uncertain.append(int(c))
        if not seen[c]:
            flags[c].append("unobserved")
        if parent in absent:
            flags[c].append("parent-missing")
            report.parent_missing.append(int(c))
        wall_id = None
        if parent == Root.WALL and variant == "full":
            wall_id = wall_alignment(geometry[c], shell_used, config)[1]
        scores = {k: float(row[k]) for k in ("V", "G", "Phi", "shell", "S")}
        scores["margin"] = float(margin)
        scores["visible_frames"] = float(seen[c])
        edges.append(Edge(c, rel, parent, float(np.clip(row["S"], 0.0, 1.0)), scores, tuple(flags[c]), wall_id))
        report.candidates[int(c)] = [
            {**_cand_json(r["candidate"]), **{k: round(float(r[k]), 4) for k in ("V", "G", "Phi", "shell", "S")}}
            for r in rows
        ]
    graph = SceneGraph(tuple(edges))
    # an edge to a missing parent dangles by design; every other forest property must hold
    problems = SceneGraph(tuple(replace(e, parent=Root.FLOOR) if e.parent in absent else e for e in edges)).check()
    if problems:  # cannot happen by construction; fail loudly rather than hand on a broken graph
        raise RuntimeError("fusion produced an invalid scene graph: " + "; ".join(problems))
    report.seconds = time.perf_counter() - start
    return graph, report


def fuse(
    predictions: list[FramePrediction],
    capture: Capture,
    shell: RoomShell | None,
    config: SceneGraphConfig,
    missing: set[int] | frozenset[int] = frozenset(),
    predictor: RelationPredictor | None = None,
) -> SceneGraph:
    """The fused scene graph (see ``fuse_with_report`` for the report)."""
    return fuse_with_report(predictions, capture, shell, config, missing, predictor)[0]
