"""MuJoCo's own compiler on MJCF files: the reference the MJCF importer is
checked against (tests/tests/mjcf.rs). For each file named on the command
line, prints one JSON line: the bodies as the importer makes them (a body
with joints, a mocap body or a child of the world, with the bodies welded
to it without joints), each with its mass, centre of mass and inertia
about it in the world at qpos0, combined here from MuJoCo's per-body
values by the parallel axis theorem; and every joint's world anchor,
axis, range (when limited and limits are on) and armature; the
gravity and whether contacts act, as <option><flag> leaves them. The configuration is qpos0 with each
limited hinge or slide coordinate outside its range moved to the nearer
limit, where the importer starts it (MuJoCo starts it outside and lets the
limit push it in). Meshes' masses come from their convex hulls
(`inertia="convex"`), as the importer's do. Names as the importer gives them: MuJoCo's,
or body<id> / joint<id> where the file has none."""

import json
import sys

import mujoco
import numpy as np


def compile_file(path):
    spec = mujoco.MjSpec.from_file(path)
    # A mesh's mass from its convex hull, as the importer takes it (MuJoCo's
    # default "legacy" sums unsigned pyramids from a centre, which differs
    # on a mesh that is not convex).
    for mesh in spec.meshes:
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_CONVEX
    m = spec.compile()
    d = mujoco.MjData(m)
    # What <option><flag> switches off acts in MuJoCo's step, not its
    # compiler: the limits, gravity and contacts the step enforces.
    off = int(m.opt.disableflags)
    bits = mujoco.mjtDisableBit
    constraint = off & bits.mjDSBL_CONSTRAINT
    limited = [bool(m.jnt_limited[j]) and not (constraint or off & bits.mjDSBL_LIMIT) for j in range(m.njnt)]
    gravity = [0.0, 0.0, 0.0] if off & bits.mjDSBL_GRAVITY else m.opt.gravity.tolist()
    # Contacts act, and some geom takes part in them (a geom with contype
    # and conaffinity 0 is visual only, as the importer takes it).
    contacts = not (constraint or off & bits.mjDSBL_CONTACT) and any(
        m.geom_contype[g] or m.geom_conaffinity[g] for g in range(m.ngeom)
    )
    for j in range(m.njnt):
        if limited[j] and m.jnt_type[j] in (2, 3):
            a = m.jnt_qposadr[j]
            d.qpos[a] = min(max(d.qpos[a], m.jnt_range[j][0]), m.jnt_range[j][1])
    mujoco.mj_kinematics(m, d)

    def body_name(b):
        n = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
        return n if n else f"body{b}"

    def joint_name(j):
        n = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        return n if n else f"joint{j}"

    top = [0] * m.nbody
    for b in range(1, m.nbody):
        parent = m.body_parentid[b]
        own = m.body_jntnum[b] > 0 or parent == 0 or m.body_mocapid[b] >= 0
        top[b] = b if own else top[parent]
    bodies = []
    for t in range(1, m.nbody):
        if top[t] != t:
            continue
        members = [b for b in range(1, m.nbody) if top[b] == t]
        mass = sum(m.body_mass[b] for b in members)
        if mass <= 0:
            bodies.append({"name": body_name(t), "mass": 0.0})
            continue
        com = sum(m.body_mass[b] * d.xipos[b] for b in members) / mass
        inertia = np.zeros((3, 3))
        for b in members:
            r = d.ximat[b].reshape(3, 3)
            own = r @ np.diag(m.body_inertia[b]) @ r.T
            x = d.xipos[b] - com
            inertia += own + m.body_mass[b] * (np.dot(x, x) * np.eye(3) - np.outer(x, x))
        bodies.append(
            {
                "name": body_name(t),
                "mass": float(mass),
                "com": com.tolist(),
                "inertia": inertia.tolist(),
                "members": [body_name(b) for b in members],
                # MuJoCo keeps mesh vertices in single precision.
                "mesh": any(
                    m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
                    for g in range(m.ngeom)
                    if m.geom_bodyid[g] in members
                ),
            }
        )
    kinds = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}
    # The bound of the torque a joint's torque actuator (a fixed gain, no
    # bias) puts on it: gear times the force range and gain times the
    # control range, the tighter (None without a range; "several" where
    # more than one drives the joint).
    effort = {}
    for a in range(m.nu):
        if m.actuator_trntype[a] != 0 or m.actuator_gaintype[a] != 0 or np.any(m.actuator_biasprm[a][:3]):
            continue
        j = int(m.actuator_trnid[a][0])
        gear = abs(m.actuator_gear[a][0])
        bounds = []
        if m.actuator_forcelimited[a]:
            bounds.append(gear * np.abs(m.actuator_forcerange[a]).max())
        if m.actuator_ctrllimited[a]:
            bounds.append(gear * abs(m.actuator_gainprm[a][0]) * np.abs(m.actuator_ctrlrange[a]).max())
        effort[j] = "several" if j in effort else (float(min(bounds)) if bounds else None)
    joints = []
    for j in range(m.njnt):
        joints.append(
            {
                "name": joint_name(j),
                "type": kinds[int(m.jnt_type[j])],
                "body": body_name(m.jnt_bodyid[j]),
                "anchor": d.xanchor[j].tolist(),
                "axis": d.xaxis[j].tolist(),
                "range": m.jnt_range[j].tolist() if limited[j] else None,
                "effort": effort.get(j),
                "armature": float(m.dof_armature[m.jnt_dofadr[j]]),
            }
        )
    # The geoms MuJoCo's viewer draws by default (groups 0 to 2) on bodies
    # other than the world: their type, size, colour and world pose (a
    # mesh's frame is MuJoCo's re-centred one: type and colour only).
    names = {2: "sphere", 3: "capsule", 4: "ellipsoid", 5: "cylinder", 6: "box", 7: "mesh"}
    geoms = []
    for g in range(m.ngeom):
        kind = names.get(int(m.geom_type[g]))
        if m.geom_bodyid[g] == 0 or kind is None or not 0 <= m.geom_group[g] <= 2:
            continue
        geoms.append(
            {
                "type": kind,
                "size": m.geom_size[g].tolist(),
                # As MuJoCo draws it: the material's colour unless the
                # geom's differs from the default grey.
                "rgba": (
                    m.mat_rgba[m.geom_matid[g]]
                    if m.geom_matid[g] >= 0 and np.allclose(m.geom_rgba[g], [0.5, 0.5, 0.5, 1])
                    else m.geom_rgba[g]
                ).tolist(),
                "pos": d.geom_xpos[g].tolist(),
                "mat": d.geom_xmat[g].reshape(3, 3).tolist(),
            }
        )
    return {"bodies": bodies, "joints": joints, "geoms": geoms, "timestep": m.opt.timestep,
            "gravity": gravity, "contacts": contacts}


for path in sys.argv[1:]:
    try:
        out = compile_file(path)
    except Exception as e:  # the file's problem, said in its line
        out = {"error": str(e)}
    out["file"] = path
    print(json.dumps(out))
