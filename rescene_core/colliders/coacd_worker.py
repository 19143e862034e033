"""Run CoACD on one mesh in its own process (``python -I coacd_worker.py IN.npz OUT.npz``).

CoACD can take long or crash on bad meshes; the exporter runs this module in a subprocess with a time
limit (rescene_core/colliders/decompose.py) so neither takes the export down. IN.npz holds ``vertices``
float64 [v, 3], ``faces`` int64 [f, 3] and ``params`` (a JSON string of ``coacd.run_coacd`` keywords);
OUT.npz gets ``vertices`` float64 [n, 3], ``faces`` int64 [m, 3] of every convex piece concatenated, and
``vertex_offsets`` / ``face_offsets`` int64 [pieces + 1] (CSR; face indices local to their piece).

It imports numpy, coacd and rescene_core.io (for the atomic write; about 15 ms), not the exporter's
package, whose trimesh/scipy imports would cost seconds per object on a loaded machine.
"""

from __future__ import annotations

import io
import json
import sys

import numpy as np

from rescene_core.io import write_bytes_atomic


def main(argv: list[str]) -> int:
    import coacd

    src, dst = argv
    data = np.load(src)
    params = json.loads(str(data["params"]))
    coacd.set_log_level("error")
    parts = coacd.run_coacd(coacd.Mesh(np.asarray(data["vertices"]), np.asarray(data["faces"])), **params)
    verts = [np.asarray(v, np.float64).reshape(-1, 3) for v, _ in parts]
    faces = [np.asarray(f, np.int64).reshape(-1, 3) for _, f in parts]
    out = io.BytesIO()
    np.savez(
        out,
        vertices=np.concatenate(verts) if verts else np.zeros((0, 3)),
        faces=np.concatenate(faces) if faces else np.zeros((0, 3), np.int64),
        vertex_offsets=np.concatenate([[0], np.cumsum([len(v) for v in verts])]).astype(np.int64),
        face_offsets=np.concatenate([[0], np.cumsum([len(f) for f in faces])]).astype(np.int64),
    )
    write_bytes_atomic(dst, out.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
