"""One work-precision case with MuJoCo, for cosim-peers.

Usage: python3 mujoco_case.py SCENE.toml OUT.bin LABELS INTEGRATOR

Builds an MJCF model from our scene file the way a MuJoCo user would
(bodies on free joints, spherical and revolute joints as nested bodies with
ball and hinge joints, spheres, capsules and boxes as their geoms with the
scene's inertia, planes as plane geoms, MuJoCo's default solver and contact
parameters),
steps it, and writes the trajectory as little-endian float64 records:
t, then per body x(3) q(4, w first) v(3) w(3) in the world frame, then the
normal force of each contact named in LABELS (comma-separated "a/b").
Prints one JSON line: MuJoCo's version, steps, and the median wall time
of a run timed with mujoco.rollout (C loop, no Python per step).
"""

import json
import math
import statistics
import sys
import time
import tomllib

import mujoco
import numpy as np
from mujoco import rollout


def qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return [
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ]


def qconj(q):
    return [q[0], -q[1], -q[2], -q[3]]


def rotate(q, v):
    """v turned by the unit quaternion q ([w, x, y, z])."""
    return qmul(qmul(q, [0.0] + list(v)), qconj(q))[1:]


def unrotate(q, v):
    """A world vector in the frame q: R(q)^T v."""
    return rotate(qconj(q), v)


IDENTITY = [1.0, 0.0, 0.0, 0.0]


def orientation(b):
    return b.get("orientation", IDENTITY)


def geom_shape(b):
    """MJCF type and size: a capsule along its local z as ours (radius,
    half its segment), a box by its half extents."""
    if "half_extents" in b:
        e = b["half_extents"]
        return "box", f"{e[0]} {e[1]} {e[2]}"
    if "half_length" in b:
        return "capsule", f'{b["radius"]} {b["half_length"]}'
    return "sphere", f'{b["radius"]}'


def rotational_inertia(b):
    """A scalar for the velocity projection's weights."""
    if "inertia" in b:
        return sum(b["inertia"][0:3]) / 3.0
    return 0.4 * b["mass"] * b["radius"] ** 2


def mjcf(scene, integrator="Euler"):
    sim = scene["sim"]
    h = sim["dt"]
    bodies = scene.get("body", [])
    planes = scene.get("plane", [])
    joints = scene.get("joint", [])
    sphere_contacts = sim.get("sphere_contacts", True)
    g = sim.get("gravity", [0.0, 0.0, -9.81])
    names = [b["name"] for b in bodies]

    # Restitution: MuJoCo has no coefficient; a user sets the contact's
    # damping ratio so that the soft contact's own bounce gives e:
    # e = exp(-zeta pi / sqrt(1 - zeta^2)), time constant 2h (its minimum).
    e = max([b.get("restitution", 0.0) for b in bodies] + [p.get("restitution", 0.0) for p in planes] + [0.0])
    solref = ""
    if e > 0:
        le = math.log(e)
        zeta = -le / math.sqrt(math.pi ** 2 + le ** 2)
        solref = f'solref="{max(0.02, 2 * h)} {zeta}"'

    # Frictionless geoms get condim 1, as a MuJoCo user sets them: with the
    # default condim 3 and mu = 0 the pyramidal cone degenerates (measured:
    # forces of 1e3 N on a 10 N equilibrium).
    def condim(x):
        return 'condim="1"' if x.get("friction", 0.5) == 0 else ""

    # Tree: each body's parent is the other side of its one joint.
    parent = {}
    for j in joints:
        a, b = j["body_a"], j["body_b"]
        parent[b] = (a, j)
    children = {}
    for b, (a, j) in parent.items():
        children.setdefault(a, []).append((b, j))

    if sphere_contacts:
        sphere_bits, plane_bits = 'contype="1" conaffinity="1"', 'contype="1" conaffinity="1"'
    else:
        sphere_bits, plane_bits = 'contype="1" conaffinity="2"', 'contype="2" conaffinity="1"'

    def body_xml(name, origin, turn):
        # MJCF nests frames: pose, joint anchor and axis in the parent's
        # and the body's own frame.
        b = bodies[names.index(name)]
        q = orientation(b)
        x = unrotate(turn, [b["position"][k] - origin[k] for k in range(3)])
        r = qmul(qconj(turn), q)
        out = f'<body name="{name}" pos="{x[0]} {x[1]} {x[2]}" quat="{r[0]} {r[1]} {r[2]} {r[3]}">'
        if name in parent:
            j = parent[name][1]
            anchor = unrotate(q, [j["anchor"][k] - b["position"][k] for k in range(3)])
            kind = {"spherical": "ball", "revolute": "hinge"}[j.get("type", "spherical")]
            axis = ""
            if kind == "hinge":
                a = unrotate(q, j["axis"])
                axis = f'axis="{a[0]} {a[1]} {a[2]}"'
            out += (
                f'<joint name="{j["name"]}" type="{kind}" pos="{anchor[0]} {anchor[1]} {anchor[2]}" '
                f'{axis} damping="0" armature="0"/>'
            )
        else:
            out += "<freejoint/>"
        mass = f'mass="{b["mass"]}"'
        if "inertia" in b:
            i = b["inertia"]
            out += f'<inertial pos="0 0 0" mass="{b["mass"]}" fullinertia="{" ".join(str(v) for v in i)}"/>'
            mass = ""
        kind, size = geom_shape(b)
        out += (
            f'<geom name="{name}" type="{kind}" size="{size}" {mass} '
            f'friction="{b.get("friction", 0.5)} 0 0" {condim(b)} {sphere_bits} {solref}/>'
        )
        for c, _ in children.get(name, []):
            out += body_xml(c, b["position"], q)
        return out + "</body>"

    world = ""
    for p in planes:
        n = p["normal"]
        pt = p["point"]
        world += (
            f'<geom name="{p["name"]}" type="plane" size="0 0 1" pos="{pt[0]} {pt[1]} {pt[2]}" '
            f'zaxis="{n[0]} {n[1]} {n[2]}" friction="{p.get("friction", 0.5)} 0 0" {condim(p)} {plane_bits} {solref}/>'
        )
    for b in bodies:
        if b["name"] not in parent or parent[b["name"]][0] == "world":
            world += body_xml(b["name"], [0.0, 0.0, 0.0], IDENTITY)
    pairs = ""
    if sphere_contacts:
        # MuJoCo filters parent-child contacts; our joined spheres collide.
        for b, (a, _) in parent.items():
            if a != "world":
                pairs += f'<pair geom1="{a}" geom2="{b}" friction="{bodies[names.index(b)].get("friction", 0.5)} {bodies[names.index(b)].get("friction", 0.5)} 0 0 0"/>'
    xml = (
        f'<mujoco><option timestep="{h}" gravity="{g[0]} {g[1]} {g[2]}" integrator="{integrator}"/>'
        f"<worldbody>{world}</worldbody>"
        + (f"<contact>{pairs}</contact>" if pairs else "")
        + "</mujoco>"
    )
    return xml


def main():
    scene_path, out_path, labels, integrator = sys.argv[1:5]
    labels = [l for l in labels.split(",") if l]
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    sim = scene["sim"]
    steps = int(sim["steps"])
    m = mujoco.MjModel.from_xml_string(mjcf(scene, integrator))
    d = mujoco.MjData(m)
    bodies = scene.get("body", [])
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b["name"]) for b in bodies]
    order = {b["name"]: i for i, b in enumerate(bodies)}

    def set_initial(d):
        mujoco.mj_resetData(m, d)
        for b, bid in zip(bodies, ids):
            jnt = m.body_jntadr[bid]
            if m.jnt_type[jnt] == mujoco.mjtJoint.mjJNT_FREE:
                qv = m.jnt_dofadr[jnt]
                d.qvel[qv:qv + 3] = b.get("velocity", [0, 0, 0])
                # A free joint's angular velocity is in the body's frame.
                d.qvel[qv + 3:qv + 6] = unrotate(orientation(b), b.get("angular_velocity", [0, 0, 0]))
            d.xfrc_applied[bid, 0:3] = b.get("force", [0, 0, 0])
        # Bodies on ball joints: MuJoCo's state is joint velocities, ours
        # body twists. Take the joint velocities closest to the scene's
        # twists in the kinetic-energy norm: the same projection our
        # engine's first step makes.
        jointed = [i for i, bid in enumerate(ids) if m.jnt_type[m.body_jntadr[bid]] != mujoco.mjtJoint.mjJNT_FREE]
        if jointed:
            mujoco.mj_forward(m, d)
            rows, target, weight = [], [], []
            for i in jointed:
                b, bid = bodies[i], ids[i]
                jp = np.zeros((3, m.nv))
                jr = np.zeros((3, m.nv))
                mujoco.mj_jacBody(m, d, jp, jr, bid)
                rows += [jp, jr]
                target += list(b.get("velocity", [0, 0, 0])) + list(b.get("angular_velocity", [0, 0, 0]))
                inertia = rotational_inertia(b)
                weight += [b["mass"]] * 3 + [inertia] * 3
            jac = np.vstack(rows)
            w = np.sqrt(np.array(weight))[:, None]
            free = [k for k in range(m.nv) if np.any(jac[:, k])]
            sol, *_ = np.linalg.lstsq(w * jac[:, free], w[:, 0] * np.array(target), rcond=None)
            d.qvel[free] = sol
        # Joint torques: +torque on body_b, -torque on body_a (world frame).
        for j in scene.get("joint", []):
            tau = np.array(j.get("torque", [0, 0, 0]), dtype=float)
            d.xfrc_applied[ids[order[j["body_b"]]], 3:6] += tau
            if j["body_a"] in order:
                d.xfrc_applied[ids[order[j["body_a"]]], 3:6] -= tau

    set_initial(d)
    rec = np.zeros((steps, 1 + 13 * len(bodies) + len(labels)))
    vel = np.zeros(6)
    f6 = np.zeros(6)
    for k in range(steps):
        mujoco.mj_step(m, d)
        row = rec[k]
        row[0] = d.time
        for i, bid in enumerate(ids):
            o = 1 + 13 * i
            row[o:o + 3] = d.xpos[bid]
            row[o + 3:o + 7] = d.xquat[bid]
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, bid, vel, 0)
            row[o + 7:o + 10] = vel[3:6]
            row[o + 10:o + 13] = vel[0:3]
        for c in range(d.ncon):
            con = d.contact[c]
            n1 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, con.geom1)
            n2 = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, con.geom2)
            # Our names: sphere first, spheres in scene order.
            if n1 not in order or (n2 in order and order[n2] < order[n1]):
                n1, n2 = n2, n1
            label = f"{n1}/{n2}"
            if label in labels:
                mujoco.mj_contactForce(m, d, c, f6)
                row[1 + 13 * len(bodies) + labels.index(label)] += f6[0]
    rec.astype("<f8").tofile(out_path)

    # Timing: whole runs in C with rollout, median, until 0.3 s are spent.
    set_initial(d)
    size = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    s0 = np.zeros((1, size))
    mujoco.mj_getState(m, d, s0[0], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    times = []
    while sum(times) < 0.3 and len(times) < 9:
        set_initial(d)
        t0 = time.perf_counter()
        rollout.rollout(m, d, s0, nstep=steps)
        times.append(time.perf_counter() - t0)
    print(json.dumps({"version": mujoco.__version__, "steps": steps, "seconds": statistics.median(times)}))


if __name__ == "__main__":
    main()
