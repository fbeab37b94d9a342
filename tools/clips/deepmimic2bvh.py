#!/usr/bin/env python3
"""Converts a DeepMimic humanoid3d motion (the JSON `.txt` files in pybullet_data/data/motions/)
into a BVH clip plus a `<stem>.joints.toml` that maps its joints onto senc's cmu_mb rig.

Usage: deepmimic2bvh.py IN.txt OUT.bvh [--min-seconds S] [--max-gap DEG]

DeepMimic frame layout (44 numbers): duration, root position (3), root rotation (w x y z),
then local rotations of chest, neck, right hip (w x y z), right knee (angle about z),
right ankle, right shoulder (w x y z), right elbow (angle), left hip, left knee, left ankle,
left shoulder, left elbow. Y is up and the character faces +x with its right at +z; the BVH
is turned -90 degrees about y so that it faces +z with its left at +x, as senc requires of a
clip's zero pose. The skeleton offsets are DeepMimic's humanoid3d (metres; pybullet's
humanoid.urdf has them scaled by 4). DeepMimic's humanoid has no wrist or toe joints: the
BVH has `*_wrist` joints that never rotate, so the hands stay straight along the forearms.

Looping clips ("Loop": "wrap") whose last pose is within --max-gap degrees (default 30) of
their first, joint by joint, are made to close exactly (the difference is spread over the
cycle) and repeated until they last at least --min-seconds (default 8), each repetition
moved and turned on the floor so that it starts where the previous one ended (so walking
and turning go on instead of jumping back). Clips whose frame durations vary are resampled
to their median frame time.
Stdlib only.
"""
import json
import math
import sys

# --- quaternions as (w, x, y, z) -------------------------------------------------------------


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


def qnorm(q):
    n = math.sqrt(sum(c * c for c in q))
    return tuple(c / n for c in q)


def qaxis(axis, angle):
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s)


def qrot(q, v):
    w, x, y, z = qmul(qmul(q, (0.0, v[0], v[1], v[2])), qconj(q))
    return (x, y, z)


def qmat(q):
    w, x, y, z = q
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]


def zxy_euler(q):
    """Angles (degrees) z, x, y with R = Rz(z) Rx(x) Ry(y) (BVH `Zrotation Xrotation Yrotation`)."""
    m = qmat(q)
    b = math.asin(max(-1.0, min(1.0, m[2][1])))
    c = math.atan2(-m[2][0], m[2][2])
    a = math.atan2(-m[0][1], m[1][1])
    return (math.degrees(a), math.degrees(b), math.degrees(c))


def zxy_quat(z, x, y):
    return qmul(qmul(qaxis((0, 0, 1), math.radians(z)), qaxis((1, 0, 0), math.radians(x))), qaxis((0, 1, 0), math.radians(y)))


def qangle(a, b):
    d = abs(sum(x * y for x, y in zip(a, b)))
    return 2 * math.degrees(math.acos(min(1.0, d)))


# --- skeleton ---------------------------------------------------------------------------------

# DeepMimic humanoid3d (name, parent, offset in its frame). `*_wrist` joints are fixed.
JOINTS = [
    ("root", None, (0.0, 0.0, 0.0)),
    ("chest", "root", (0.0, 0.236151, 0.0)),
    ("neck", "chest", (0.0, 0.223894, 0.0)),
    ("right_hip", "root", (0.0, 0.0, 0.084887)),
    ("right_knee", "right_hip", (0.0, -0.421546, 0.0)),
    ("right_ankle", "right_knee", (0.0, -0.40987, 0.0)),
    ("right_shoulder", "chest", (-0.02405, 0.2435, 0.18311)),
    ("right_elbow", "right_shoulder", (0.0, -0.274788, 0.0)),
    ("right_wrist", "right_elbow", (0.0, -0.258947, 0.0)),
    ("left_hip", "root", (0.0, 0.0, -0.084887)),
    ("left_knee", "left_hip", (0.0, -0.421546, 0.0)),
    ("left_ankle", "left_knee", (0.0, -0.40987, 0.0)),
    ("left_shoulder", "chest", (-0.02405, 0.2435, -0.18311)),
    ("left_elbow", "left_shoulder", (0.0, -0.274788, 0.0)),
    ("left_wrist", "left_elbow", (0.0, -0.258947, 0.0)),
]
# End sites: top of the head, toes (the foot box runs forward of the ankle), fingertips.
END_SITES = {
    "neck": (0.0, 0.2, 0.0),
    "right_ankle": (0.13, -0.05, 0.0),
    "left_ankle": (0.13, -0.05, 0.0),
    "right_wrist": (0.0, -0.08, 0.0),
    "left_wrist": (0.0, -0.08, 0.0),
}
# Which numbers of a frame hold which joint's local rotation: (start, kind).
LAYOUT = {
    "chest": (8, "q"),
    "neck": (12, "q"),
    "right_hip": (16, "q"),
    "right_knee": (20, "a"),
    "right_ankle": (21, "q"),
    "right_shoulder": (25, "q"),
    "right_elbow": (29, "a"),
    "left_hip": (30, "q"),
    "left_knee": (34, "a"),
    "left_ankle": (35, "q"),
    "left_shoulder": (39, "q"),
    "left_elbow": (43, "a"),
}

JOINTS_TOML = """\
# DeepMimic humanoid3d (converted by deepmimic2bvh.py) onto senc's cmu_mb rig.
# The humanoid has one chest joint at the waist: the whole spine turns with it.
# It has no wrists (the *_wrist joints never rotate) and the neck joint carries the head.
same_names = false

[joints]
Hips = "root"
LowerBack = "chest"
Spine = "chest"
Spine1 = "chest"
Neck = "neck"
Head = "neck"
RightArm = "right_shoulder"
RightForeArm = "right_elbow"
RightHand = "right_wrist"
LeftArm = "left_shoulder"
LeftForeArm = "left_elbow"
LeftHand = "left_wrist"
RightUpLeg = "right_hip"
RightLeg = "right_knee"
RightFoot = "right_ankle"
LeftUpLeg = "left_hip"
LeftLeg = "left_knee"
LeftFoot = "left_ankle"
"""

# Turn from DeepMimic's frame (faces +x, right at +z) to senc's (faces +z, left at +x).
TURN = qaxis((0, 1, 0), -math.pi / 2)


def turn_vec(v):
    return qrot(TURN, v)


def turn_rot(q):
    return qnorm(qmul(qmul(TURN, q), qconj(TURN)))


def parse_frame(f):
    pos = (f[1], f[2], f[3])
    rots = {"root": qnorm((f[4], f[5], f[6], f[7]))}
    for name, (i, kind) in LAYOUT.items():
        rots[name] = qnorm(tuple(f[i : i + 4])) if kind == "q" else qaxis((0, 0, 1), f[i])
    for name in ("right_wrist", "left_wrist"):
        rots[name] = (1.0, 0.0, 0.0, 0.0)
    return pos, rots


def slerp(a, b, t):
    d = sum(x * y for x, y in zip(a, b))
    if d < 0:
        b, d = tuple(-c for c in b), -d
    if d > 0.9995:
        return qnorm(tuple(x + t * (y - x) for x, y in zip(a, b)))
    th = math.acos(d)
    sa, sb = math.sin((1 - t) * th) / math.sin(th), math.sin(t * th) / math.sin(th)
    return qnorm(tuple(sa * x + sb * y for x, y in zip(a, b)))


def resample(frames, times, dt):
    """Frames at k * dt from frames at `times` (slerp for rotations, linear for the root)."""
    out, i, t = [], 0, 0.0
    while t <= times[-1] + 1e-9:
        while i + 2 < len(times) and times[i + 1] < t:
            i += 1
        a = min(1.0, max(0.0, (t - times[i]) / (times[i + 1] - times[i])))
        (p0, r0), (p1, r1) = frames[i], frames[i + 1]
        pos = tuple(x + a * (y - x) for x, y in zip(p0, p1))
        out.append((pos, {j: slerp(r0[j], r1[j], a) for j in r0}))
        t += dt
    return out


def mismatch(frames):
    """Largest angle (degrees) between a joint's rotations in the first and last frames."""
    return max(qangle(frames[0][1][j], frames[-1][1][j]) for j in LAYOUT)


def heading(q):
    """Yaw (about +y) of the character's forward axis (+x in DeepMimic's frame)."""
    fwd = qrot(q, (1.0, 0.0, 0.0))
    return math.atan2(-fwd[2], fwd[0])


def close_loop(frames):
    """Spreads the difference between the last and the first pose over the cycle, so that the
    last frame is the first one moved and turned on the floor (and copies join smoothly)."""
    n = len(frames)
    (p0, r0), (pl, rl) = frames[0], frames[-1]
    dh = heading(rl["root"]) - heading(r0["root"])
    want_root = qmul(qaxis((0, 1, 0), dh), r0["root"])
    delta = {j: qmul(r0[j], qconj(rl[j])) for j in LAYOUT}
    delta["root"] = qmul(want_root, qconj(rl["root"]))
    out = []
    for f, (p, r) in enumerate(frames):
        t = f / (n - 1)
        r2 = dict(r)
        for j, d in delta.items():
            r2[j] = qnorm(qmul(slerp((1.0, 0.0, 0.0, 0.0), d, t), r[j]))
        out.append(((p[0], p[1] + t * (p0[1] - pl[1]), p[2]), r2))
    return out


def tile(frames, dt, min_seconds):
    """Repeats a cycle until it lasts min_seconds, each copy moved and turned on the floor so
    that it starts where the previous one ended. With A, B the floor placements (yaw and
    floor position of the root) of the first and last frames, copy k is T_k applied to the
    cycle, T_0 = identity and T_{k+1} = T_k S with S = B A^-1."""
    a, b = frames[0][0], frames[-1][0]
    dh = heading(frames[-1][1]["root"]) - heading(frames[0][1]["root"])
    turn = qaxis((0, 1, 0), dh)
    s0 = qrot(turn, (-a[0], 0.0, -a[2]))
    s0 = (s0[0] + b[0], 0.0, s0[2] + b[2])  # S(x) = turn x + s0 on the floor
    out, copies = list(frames), 1
    k_yaw, k_off = 0.0, (0.0, 0.0, 0.0)  # T_k(x) = Ry(k_yaw) x + k_off
    while (len(out) - 1) * dt < min_seconds:
        # T_{k+1} = T_k S
        t = qrot(qaxis((0, 1, 0), k_yaw), s0)
        k_off = (k_off[0] + t[0], 0.0, k_off[2] + t[2])
        k_yaw += dh
        ky = qaxis((0, 1, 0), k_yaw)
        for p, r in frames[1:]:
            q = qrot(ky, p)
            r2 = dict(r)
            r2["root"] = qnorm(qmul(ky, r["root"]))
            out.append(((q[0] + k_off[0], q[1], q[2] + k_off[2]), r2))
        copies += 1
    return out, copies


def fmt(x):
    s = f"{x:.6f}"
    return "0.000000" if s == "-0.000000" else s


def write_bvh(path, frames, dt):
    children = {}
    for name, parent, _ in JOINTS:
        children.setdefault(parent, []).append(name)
    offsets = {name: turn_vec(off) for name, _, off in JOINTS}
    lines = ["HIERARCHY"]
    order = []

    def emit(name, depth):
        ind = "\t" * depth
        order.append(name)
        kw = "ROOT" if depth == 0 else "JOINT"
        lines.append(f"{ind}{kw} {name}")
        lines.append(f"{ind}{{")
        o = offsets[name]
        lines.append(f"{ind}\tOFFSET {fmt(o[0])} {fmt(o[1])} {fmt(o[2])}")
        if depth == 0:
            lines.append(f"{ind}\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
        else:
            lines.append(f"{ind}\tCHANNELS 3 Zrotation Xrotation Yrotation")
        for c in children.get(name, []):
            emit(c, depth + 1)
        if name in END_SITES:
            e = turn_vec(END_SITES[name])
            lines.append(f"{ind}\tEnd Site")
            lines.append(f"{ind}\t{{")
            lines.append(f"{ind}\t\tOFFSET {fmt(e[0])} {fmt(e[1])} {fmt(e[2])}")
            lines.append(f"{ind}\t}}")
        lines.append(f"{ind}}}")

    emit("root", 0)
    lines.append("MOTION")
    lines.append(f"Frames: {len(frames)}")
    lines.append(f"Frame Time: {dt:.7f}")
    worst = 0.0
    for pos, rots in frames:
        p = turn_vec(pos)
        vals = [p[0], p[1], p[2]]
        for name in order:
            q = turn_rot(rots[name])
            e = zxy_euler(q)
            worst = max(worst, qangle(q, zxy_quat(*e)))
            vals.extend(e)
        lines.append(" ".join(fmt(v) for v in vals))
    if worst > 0.01:
        raise SystemExit(f"internal error: Euler round trip off by {worst} degrees")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    args = sys.argv[1:]
    min_seconds, max_gap = 8.0, 30.0
    for flag in ("--min-seconds", "--max-gap"):
        if flag in args:
            i = args.index(flag)
            if flag == "--min-seconds":
                min_seconds = float(args[i + 1])
            else:
                max_gap = float(args[i + 1])
            del args[i : i + 2]
    if len(args) != 2:
        raise SystemExit(__doc__)
    src, out = args
    d = json.load(open(src))
    raw = d["Frames"]
    if len(raw[0]) != 44:
        raise SystemExit(f"{src}: {len(raw[0])} numbers a frame; a humanoid3d motion has 44")
    dts = [f[0] for f in raw[:-1]]
    frames = [parse_frame(f) for f in raw]
    dt = sorted(dts)[len(dts) // 2]
    if max(abs(x - dt) for x in dts) > 1e-3 * dt:
        times = [0.0]
        for x in dts:
            times.append(times[-1] + x)
        frames = resample(frames, times, dt)
    copies, note = 1, "not a loop"
    if d.get("Loop") == "wrap":
        gap = mismatch(frames)
        if gap <= max_gap:
            frames, copies = tile(close_loop(frames), dt, min_seconds)
            note = f"loop closed ({gap:.0f} deg), {copies} cycle(s)"
        else:
            note = f"loop left open: last pose is {gap:.0f} deg off the first"
    write_bvh(out, frames, dt)
    stem = out[: -len(".bvh")] if out.endswith(".bvh") else out
    with open(stem + ".joints.toml", "w") as f:
        f.write(JOINTS_TOML)
    print(f"{out}: {len(frames)} frames at {1 / dt:.2f} fps ({(len(frames) - 1) * dt:.2f} s); {note}")


if __name__ == "__main__":
    main()
