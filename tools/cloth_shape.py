"""Shape of simulated garment frames against another frame: what a distance does not show.

    python3 tools/cloth_shape.py DIR FRAME [FRAME ...] [--against OTHER_DIR/cloth_NNNN.obj]

DIR holds `cargo xtask simulate` output (`cloth_NNNN.obj`, `body_NNNN.obj`). For each
frame it prints, against DIR's frame 0 (the skinned start) or against `--against`:
(after a first line with the reference's mean and longest edge)
- the growth of the total area, and the median face-area and edge-length ratios;
- the faces' principal stretches (the larger and the smaller, medians) and the share of
  faces with either of them more than 10 % off 1;
- the median stretch of the faces along the hoop (around the vertical axis through the
  reference's centroid) and along the meridian (the face's other in-plane direction): a
  hanging skirt or sleeve shortens its hoop and lengthens its meridian;
- the length of each boundary loop (sorted by height), and for the lowest loop (a hem) its
  mean radius about its own centroid's vertical axis and the spread of that radius left
  after the first three Fourier modes around the loop (folds);
- the share of cloth vertices within 1 cm of a body vertex;
- the mean offset (x, y, z) of the cloth from the reference carried along by the body:
  each reference vertex moved as its nearest body vertex (in `body_0000.obj`) has moved
  since frame 0, translation only (a drift of the whole garment against the body shows
  here; rotations of body parts blur it).
Needs numpy only.
"""
import argparse
from collections import Counter
from pathlib import Path

import numpy as np


def load(path):
    v, f = [], []
    for line in open(path):
        if line.startswith("v "):
            v.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            f.append([int(x.split("/")[0]) - 1 for x in line.split()[1:4]])
    return np.array(v), np.array(f)


def face_areas(v, f):
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def boundary_loops(f):
    count = Counter()
    for tri in f:
        for i in range(3):
            a, b = tri[i], tri[(i + 1) % 3]
            count[(min(a, b), max(a, b))] += 1
    edges = [e for e, c in count.items() if c == 1]
    adj = {}
    for a, b in edges:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    seen, loops = set(), []
    for start in adj:
        if start in seen:
            continue
        comp, stack = set(), [start]
        while stack:
            x = stack.pop()
            if x not in comp:
                comp.add(x)
                stack += adj[x]
        seen |= comp
        loops.append([e for e in edges if e[0] in comp])
    return loops


def hem_radius(v, loop):
    ids = sorted({i for e in loop for i in e})
    p = v[ids]
    r = p - p.mean(0)
    r[:, 1] = 0.0
    rad = np.linalg.norm(r, axis=1)
    th = np.arctan2(r[:, 2], r[:, 0])
    basis = np.stack([np.ones_like(th)] + [g(k * th) for k in (1, 2, 3) for g in (np.cos, np.sin)], 1)
    residual = rad - basis @ np.linalg.lstsq(basis, rad, rcond=None)[0]
    return rad.mean(), residual.std()


def stretches(v0, v, f):
    """Per face of nonzero reference area: the larger and the smaller principal stretch from
    `v0` to `v`, and the stretch along the hoop (around the vertical axis through `v0`'s
    centroid) and along the meridian (the face's other in-plane direction), all from one
    deformation gradient `F` (3×2) in an orthonormal basis of the reference face's plane."""
    e1, e2 = v0[f[:, 1]] - v0[f[:, 0]], v0[f[:, 2]] - v0[f[:, 0]]
    n = np.cross(e1, e2)
    keep = np.linalg.norm(n, axis=1) > 1e-12
    n, e1, e2, f = n[keep], e1[keep], e2[keep], f[keep]
    n /= np.linalg.norm(n, axis=1)[:, None]
    b1 = e1 / np.linalg.norm(e1, axis=1)[:, None]
    b2 = np.cross(n, b1)
    rest = np.stack([np.stack([(e1 * b1).sum(1), (e2 * b1).sum(1)], 1),
                     np.stack([(e1 * b2).sum(1), (e2 * b2).sum(1)], 1)], 1)
    now = np.stack([v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]], 2)
    grad = now @ np.linalg.inv(rest)
    s = np.linalg.svd(grad, compute_uv=False)
    # The hoop direction in the face's plane, in the (b1, b2) basis; the meridian is its
    # in-plane normal. Faces whose plane holds no hoop direction (normal vertical) are left
    # out of those two.
    hoop = np.cross([0.0, 1.0, 0.0], v0[f].mean(1) - v0.mean(0))
    h = np.stack([(hoop * b1).sum(1), (hoop * b2).sum(1)], 1)
    ok = np.linalg.norm(h, axis=1) > 1e-9
    h = h[ok] / np.linalg.norm(h[ok], axis=1)[:, None]
    m = np.stack([-h[:, 1], h[:, 0]], 1)
    along = lambda d: np.linalg.norm(np.einsum("fij,fj->fi", grad[ok], d), axis=1)
    return s[:, 0], s[:, 1], along(h), along(m)


def nearest(points, body):
    """Per point: the index of its nearest body vertex and the squared distance to it."""
    index, d2 = [], []
    for chunk in np.array_split(points, max(1, len(points) // 512)):
        d = ((chunk[:, None, :] - body[None, :, :]) ** 2).sum(-1)
        index.append(d.argmin(1))
        d2.append(d.min(1))
    return np.concatenate(index), np.concatenate(d2)


def near_body(cloth, body, within=0.01):
    return float((nearest(cloth, body)[1] < within * within).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("frames", type=int, nargs="+")
    ap.add_argument("--against", type=Path, help="reference cloth OBJ (default DIR/cloth_0000.obj)")
    a = ap.parse_args()
    v0, f = load(a.against or a.dir / "cloth_0000.obj")
    loops = sorted(boundary_loops(f), key=lambda l: v0[[e[0] for e in l], 1].mean())
    edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0)
    a0, l0 = face_areas(v0, f), np.linalg.norm(v0[edges[:, 0]] - v0[edges[:, 1]], axis=1)
    body0, _ = load(a.dir / "body_0000.obj")
    carrier = nearest(v0, body0)[0]
    print(f"reference: {len(f)} faces, mean edge {100 * l0.mean():.2f} cm, longest {100 * l0.max():.2f} cm")
    for frame in a.frames:
        v, f2 = load(a.dir / f"cloth_{frame:04d}.obj")
        assert (f2 == f).all(), "frames of different meshes"
        ar, lr = face_areas(v, f) / a0, np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1) / l0
        lengths = " ".join(f"{100 * sum(np.linalg.norm(v[i] - v[j]) for i, j in l):.1f}" for l in loops)
        radius, spread = hem_radius(v, loops[0]) if loops else (float("nan"), float("nan"))
        body, _ = load(a.dir / f"body_{frame:04d}.obj")
        s1, s2, hoop, meridian = stretches(v0, v, f)
        hoop, meridian = np.median(hoop), np.median(meridian)
        off = 100 * ((s1 > 1.1) | (s2 < 0.9)).mean()
        print(
            f"frame {frame}: area {100 * (face_areas(v, f).sum() / a0.sum() - 1):+.1f} %, "
            f"median face x{np.median(ar):.3f}, median edge x{np.median(lr):.3f}, "
            f"hoop x{hoop:.3f}, meridian x{meridian:.3f}; principal stretches (medians) "
            f"x{np.median(s1):.3f} and x{np.median(s2):.3f}, {off:.0f} % of faces off by more than 10 %; "
            f"loop lengths (cm, lowest first) {lengths}; lowest loop radius {100 * radius:.1f} cm, "
            f"spread beyond 3 modes {100 * spread:.2f} cm; within 1 cm of the body "
            f"{100 * near_body(v, body):.1f} %; offset from the start carried by the body (x, y, z) "
            + " ".join(f"{100 * c:+.1f}" for c in (v - v0 - (body[carrier] - body0[carrier])).mean(0))
            + " cm"
        )


if __name__ == "__main__":
    main()
