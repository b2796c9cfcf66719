#!/usr/bin/env python3
"""Run an exported StarNet (`starnet export`) on KITTI velodyne sweeps with onnxruntime.

The dense network is `model.onnx`; everything around it (center sampling, gathering, anchor
decoding, NMS, the camera projection for the KITTI result format) is done here from the
contract in `model.json`.

    pip install numpy onnxruntime
    python3 scripts/onnx_detect.py --export export/ --input ROOT/training/velodyne/000001.bin \
        --calib ROOT/training/calib/000001.txt --out detections/

The streaming LSTM variant's `model.onnx` is one slice step with the LSTM state as inputs and
outputs; `--stream [N]` cuts the sweep into N azimuth slices (model.json `streaming`) and runs
them in order, the state carried from zeros, then NMS over the whole sweep's boxes:

    python3 scripts/onnx_detect.py --export export/ --stream 4 --input ... --calib ... --out ...

`--golden` checks the export instead: it replays `golden.safetensors` (and, for the streaming
variant, the whole sweep of `golden_stream.safetensors`, slice by slice with the state carried)
through onnxruntime and fails unless every output is within 1e-4 of Burn's.

    python3 scripts/onnx_detect.py --export export/ --golden

Writes `{id}.txt` in KITTI's result format (boxes whose projection reaches image 2).
Centers are sampled with farthest point sampling in bird's-eye view from a seeded random start,
as the Rust pipeline does; the exact centers (and so the boxes) differ from `starnet detect`'s,
which uses its own random streams. Each center is seen as model.json `center_views` says: with
`alternate`, every second one sees its neighbourhood in the mirror and its boxes are mirrored back
(`mirror_rule`), as `starnet detect` does.
"""

import argparse
import json
import math
import os

import numpy as np

IMAGE_W, IMAGE_H = 1242, 375


def read_calib(path):
    rows = {}
    for line in open(path):
        if ":" in line:
            key, vals = line.split(":", 1)
            rows[key.strip()] = np.array([float(v) for v in vals.split()])
    p2 = rows["P2"].reshape(3, 4)
    r0 = np.eye(4)
    r0[:3, :3] = rows["R0_rect"].reshape(3, 3)
    tr = np.eye(4)
    tr[:3, :4] = rows["Tr_velo_to_cam"].reshape(3, 4)
    return p2, r0 @ tr  # image projection, LiDAR -> rectified camera


def bound(v, default):
    return default if v is None else v  # JSON has no infinity: unbounded ranges are null


def ground_rise(points, ground):
    """The ground's rise above the reference plane under each (x, y), as a function of x and y
    (starnet_data::geometry::GroundModel): each cell's `rank`-th lowest z, those more than `max_drop`
    below their window's lower quartile dropped, the minimum over the window around each; the reference
    (rise 0) where nothing lies around or outside the extent.
    `ground` None: flat ground, rise 0 everywhere."""
    if ground is None:
        return lambda x, y: np.zeros(np.shape(x), np.float32)
    cell, w, k, ext = ground["cell"], ground["window"], ground["rank"] + 1, ground["extent"]
    side = max(1, int(np.ceil(np.float32(2 * ext) / np.float32(cell))))

    def index(x, y):
        i = np.floor((np.asarray(x, np.float32) + np.float32(ext)) / np.float32(cell))
        j = np.floor((np.asarray(y, np.float32) + np.float32(ext)) / np.float32(cell))
        inside = (i >= 0) & (i < side) & (j >= 0) & (j < side)
        return np.where(inside, i * side + j, -1).astype(np.int64)

    c = index(points[:, 0], points[:, 1])
    z = points[:, 2][c >= 0]
    c = c[c >= 0]
    order = np.lexsort((z, c))
    c, z = c[order], z[order]
    first = np.r_[0, np.flatnonzero(np.diff(c)) + 1] if len(c) else np.zeros(0, np.int64)
    count = np.diff(np.r_[first, len(c)])
    floors = np.full(side * side, np.inf, np.float32)
    floors[c[first]] = z[first + np.minimum(k - 1, count - 1)]
    grid = floors.reshape(side, side)
    # Pits: a floor more than max_drop below the lower quartile (the n // 4-th of the window's n
    # floors) is no ground.
    padded = np.pad(grid, w, constant_values=np.inf)
    window = np.stack([padded[w + a:w + a + side, w + b:w + b + side]
                       for a in range(-w, w + 1) for b in range(-w, w + 1)])
    window = np.sort(window, axis=0)
    valid = np.isfinite(window).sum(0)
    quartile = np.take_along_axis(window, (valid // 4)[None], 0)[0]
    grid = np.where(np.isfinite(grid) & (grid < quartile - np.float32(ground["max_drop"])), np.inf, grid)
    for axis in (1, 0):
        padded = np.moveaxis(grid, axis, -1)
        out = np.full_like(padded, np.inf)
        for d in range(-w, w + 1):
            lo, hi = max(0, d), side + min(0, d)
            out[..., lo - d:hi - d] = np.minimum(out[..., lo - d:hi - d], padded[..., lo:hi])
        grid = np.moveaxis(out, -1, axis)
    height = grid.reshape(-1)

    def rise(x, y):
        cells = index(x, y)
        h = np.where(cells >= 0, height[np.maximum(cells, 0)], np.inf)
        return np.where(np.isfinite(h), h - np.float32(ground["reference_z"]), 0.0).astype(np.float32)

    return rise


def center_pool(points, pool, calib, rise=None):
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    if rise is not None:
        z = z - rise(x, y)
    keep = np.ones(len(points), bool)
    for axis, key in ((x, "x_range"), (y, "y_range"), (z, "z_range")):
        lo, hi = pool[key]
        keep &= (axis >= bound(lo, -np.inf)) & (axis <= bound(hi, np.inf))
    if pool["camera_frustum"] and calib is not None:
        p2, velo_to_rect = calib
        rect = np.c_[points[:, :3], np.ones(len(points))] @ velo_to_rect.T
        img = np.c_[rect[:, :3], np.ones(len(points))] @ p2.T
        u, v = img[:, 0] / img[:, 2], img[:, 1] / img[:, 2]
        keep &= (rect[:, 2] >= 0) & (u >= 0) & (u < IMAGE_W) & (v >= 0) & (v < IMAGE_H)
    return np.flatnonzero(keep)


def fps_bev(xy, n, rng, seeds=None):
    """FPS in (x, y): from a random first point, or continuing from `seeds` (not returned)."""
    dist = np.full(len(xy), np.inf)
    if seeds is not None and len(seeds):
        for c in seeds:
            dist = np.minimum(dist, ((xy - c[:2]) ** 2).sum(1))
        chosen = [int(dist.argmax())]
    else:
        chosen = [int(rng.integers(len(xy)))]
    for _ in range(1, min(n, len(xy))):
        dist = np.minimum(dist, ((xy - xy[chosen[-1]]) ** 2).sum(1))
        chosen.append(int(dist.argmax()))
    return np.array(chosen)


def gather(points, centers, num_points, radius, metric, rng):
    feats = np.zeros((len(centers), num_points, 4), np.float32)
    mask = np.zeros((len(centers), num_points), np.float32)
    axes = 2 if metric == "cylinder" else 3  # the cylinder bounds the distance in x, y only
    for c, ctr in enumerate(centers):
        near = np.flatnonzero(((points[:, :axes] - ctr[:axes]) ** 2).sum(1) <= radius * radius)
        if len(near) > num_points:
            near = rng.choice(near, num_points, replace=False)
        feats[c, : len(near), :3] = points[near, :3] - ctr
        feats[c, : len(near), 3] = points[near, 3]
        mask[c, : len(near)] = 1.0
    return feats, mask


def anchors_around(center, grid):
    g, ext = grid["grid"], grid["extent"]
    steps = [-ext + i * 2 * ext / (g - 1) for i in range(g)] if g > 1 else [0.0]
    out = []
    for ox in steps:  # offset-major (x outer, y inner), then rotation, then prior
        for oy in steps:
            for rot in grid["rotations"]:
                for p in grid["priors"]:
                    out.append([center[0] + ox, center[1] + oy, center[2] + p["z"], *p["size"], rot])
    return np.array(out, np.float64)


def decode(r, a):
    d = np.hypot(a[:, 3], a[:, 4])
    heading = a[:, 6] + r[:, 6]
    heading = -math.pi + np.mod(heading + math.pi, 2 * math.pi)
    return np.stack([a[:, 0] + r[:, 0] * d, a[:, 1] + r[:, 1] * d, a[:, 2] + r[:, 2] * a[:, 5],
                     a[:, 3] * np.exp(r[:, 3]), a[:, 4] * np.exp(r[:, 4]), a[:, 5] * np.exp(r[:, 5]),
                     heading], 1)


def with_direction(heading, dir_logits, offset):
    """Turns each heading into the half-turn of its more likely direction bin (model.json
    `direction`)."""
    bins = dir_logits.argmax(1)
    folded = np.mod(heading - offset, math.pi)
    return -math.pi + np.mod(offset + folded + math.pi * bins + math.pi, 2 * math.pi)


def corners_bev(b):
    c, s = math.cos(b[6]), math.sin(b[6])
    return [(b[0] + c * u - s * v, b[1] + s * u + c * v)
            for u, v in ((b[3] / 2, b[4] / 2), (-b[3] / 2, b[4] / 2), (-b[3] / 2, -b[4] / 2), (b[3] / 2, -b[4] / 2))]


def clip(subject, clipper):  # Sutherland-Hodgman, both convex and counter-clockwise
    out = subject
    for i in range(len(clipper)):
        a, b = clipper[i], clipper[(i + 1) % len(clipper)]
        inside = lambda p: (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0
        src, out = out, []
        for j in range(len(src)):
            p, q = src[j], src[(j + 1) % len(src)]
            if inside(q):
                if not inside(p):
                    out.append(intersect(p, q, a, b))
                out.append(q)
            elif inside(p):
                out.append(intersect(p, q, a, b))
        if not out:
            return []
    return out


def intersect(p, q, a, b):
    dx, dy = q[0] - p[0], q[1] - p[1]
    ex, ey = b[0] - a[0], b[1] - a[1]
    # p + t (q - p) on the line through a and b: cross(p + t d - a, e) = 0.
    t = (ex * (p[1] - a[1]) - ey * (p[0] - a[0])) / (dx * ey - dy * ex)
    return (p[0] + t * dx, p[1] + t * dy)


def area(poly):
    return 0.5 * abs(sum(poly[i][0] * poly[i - 1][1] - poly[i - 1][0] * poly[i][1] for i in range(len(poly))))


def iou_3d(a, b):
    inter = clip(corners_bev(a), corners_bev(b))
    overlap = max(0.0, min(a[2] + a[5] / 2, b[2] + b[5] / 2) - max(a[2] - a[5] / 2, b[2] - b[5] / 2))
    v = (area(inter) if len(inter) >= 3 else 0.0) * overlap
    return v / (a[3] * a[4] * a[5] + b[3] * b[4] * b[5] - v)


def nms(boxes, scores, iou_thr, score_thr, max_boxes):
    keep = []
    for i in np.argsort(-scores):
        if scores[i] < score_thr or len(keep) == max_boxes:
            break
        if all(iou_3d(boxes[i], boxes[j]) <= iou_thr for j in keep):
            keep.append(i)
    return keep


def vote(boxes, scores, kept, candidates, min_iou):
    """Box voting as starnet_model::nms::vote: the score-weighted mean of the candidates
    overlapping the kept box by at least min_iou; headings averaged modulo pi about the kept
    one, turned by pi when the weighted majority points the other way."""
    k = boxes[kept]
    voters = [i for i in candidates if i != kept and iou_3d(boxes[i], k) >= min_iou] + [kept]
    w = scores[voters]
    out = (w[:, None] * boxes[voters, :6]).sum(0) / w.sum()
    turn = np.array([wrap(boxes[i, 6] - k[6]) for i in voters])
    axis_turn = (w * np.array([wrap(2 * t) / 2 for t in turn])).sum() / w.sum()
    flip = math.pi if (w * np.sign(np.cos(turn))).sum() < 0 else 0.0
    return np.append(out, wrap(k[6] + axis_turn + flip))


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def image_extent(p2, x, y, z, l, w, h, ry):
    """(left, top, right, bottom) of the image projection of a camera-frame box (KITTI's bottom centre x, y, z, its
    length, width, height and ry), unclipped; None when a corner lies behind the camera."""
    c, s = math.cos(ry), math.sin(ry)
    pts = []
    for u in (l / 2, -l / 2):
        for v in (w / 2, -w / 2):
            for dy in (0.0, -h):
                px, pz = x + c * u + s * v, z - s * u + c * v
                img = p2 @ np.array([px, y + dy, pz, 1.0])
                if img[2] <= 0:
                    return None
                pts.append(img[:2] / img[2])
    pts = np.array(pts)
    return (*pts.min(0), *pts.max(0))


def kitti_line(name, b, score, calib):
    p2, velo_to_rect = calib
    x, y, z = (velo_to_rect @ np.array([b[0], b[1], b[2], 1.0]))[:3]
    h, w, l = b[5], b[4], b[3]
    ry = -math.pi + (( -b[6] - math.pi / 2) + math.pi) % (2 * math.pi)
    y += h / 2  # KITTI's location is the bottom centre, camera y down
    extent = image_extent(p2, x, y, z, l, w, h, ry)
    if extent is None:
        return None
    left, top, right, bottom = extent
    if right < 0 or bottom < 0 or left > IMAGE_W - 1 or top > IMAGE_H - 1:
        return None
    left, right = np.clip([left, right], 0, IMAGE_W - 1)
    top, bottom = np.clip([top, bottom], 0, IMAGE_H - 1)
    alpha = -math.pi + ((ry - math.atan2(x, z)) + math.pi) % (2 * math.pi)
    return (f"{name} -1 -1 {alpha:.2f} {left:.2f} {top:.2f} {right:.2f} {bottom:.2f} "
            f"{h:.2f} {w:.2f} {l:.2f} {x:.2f} {y:.2f} {z:.2f} {ry:.2f} {score:.4f}")


def read_safetensors(path):
    """Every f32 tensor of a safetensors file, by name (the format: u64 header length, JSON
    header, raw little-endian data)."""
    raw = open(path, "rb").read()
    n = int.from_bytes(raw[:8], "little")
    header = json.loads(raw[8:8 + n])
    body = raw[8 + n:]
    out = {}
    for name, t in header.items():
        if name == "__metadata__":
            continue
        lo, hi = t["data_offsets"]
        out[name] = np.frombuffer(body[lo:hi], "<f4").reshape(t["shape"])
    return out


def check_golden(export):
    """Replays the golden files through model.onnx; returns the worst |difference|."""
    spec = json.load(open(os.path.join(export, "model.json")))
    import onnxruntime as ort  # here, so that the sampling functions import with numpy alone

    session = ort.InferenceSession(os.path.join(export, "model.onnx"))
    names = [o.name for o in session.get_outputs()]
    streaming = spec.get("streaming")
    worst = 0.0
    if streaming:
        golden = read_safetensors(os.path.join(export, "golden_stream.safetensors"))
        h = streaming["lstm_hidden"]
        state = {"state_h": np.zeros((1, h), np.float32), "state_c": np.zeros((1, h), np.float32)}
        s = 0
        while f"slice{s}.points" in golden:
            feed = {k: golden[f"slice{s}.{k}"] for k in ("points", "mask", "center_valid")}
            got = dict(zip(names, session.run(None, {**feed, **state})))
            for name in names:
                want = golden[f"slice{s}.{name.removesuffix('_out')}"]
                diff = float(np.abs(got[name] - want).max())
                print(f"slice {s} {name}: max |diff| {diff:.2e}")
                worst = max(worst, diff)
            state = {"state_h": got["state_h_out"], "state_c": got["state_c_out"]}
            s += 1
    else:
        golden = read_safetensors(os.path.join(export, "golden.safetensors"))
        got = dict(zip(names, session.run(None, {"points": golden["points"], "mask": golden["mask"]})))
        for name in names:
            diff = float(np.abs(got[name] - golden[name]).max())
            print(f"{name}: max |diff| {diff:.2e}")
            worst = max(worst, diff)
    return worst


def spaced_picks(xy, most, seeds, spacing, rng):
    """FPS continued from `seeds`, at most `most` picks, stopping before the first that lies
    within `spacing` of a center (starnet_data::sampling::spaced_centers)."""
    picks = fps_bev(xy, most, rng, seeds)
    placed = [c[:2] for c in seeds] if seeds is not None else []
    kept = []
    for i in picks:
        if any(np.hypot(*(xy[i] - c)) < spacing for c in placed):
            break
        kept.append(i)
        placed.append(xy[i])
    return np.array(kept, int)


def centers_of(points, chosen, spec, rise):
    centers = points[chosen, :3].astype(np.float32)
    if spec["center_z"] == "zero":
        centers[:, 2] = 0.0
    elif spec["center_z"] == "ground":
        centers[:, 2] = rise(centers[:, 0], centers[:, 1])
    return centers


def sample_and_gather(points, pool, n, spec, rng, readable=None, rise=None):
    """FPS centers from the pool's points and their neighbourhoods in `readable` (default:
    `points`); `rise`, the ground's, lifts `center_z = "ground"` centers onto a road that is not flat."""
    chosen = pool[fps_bev(points[pool, :2].astype(np.float64), n, rng)]
    centers = centers_of(points, chosen, spec, rise)
    feats, mask = gather(points if readable is None else readable, centers, spec["num_points"],
                         spec["radius"], spec.get("gather_metric", "ball"), rng)
    return centers, feats, mask


def mirrored_centers(spec, n):
    """Which of `n` centers, in sampling order, see their neighbourhood in the mirror (model.json
    `center_views`; exports older than it have none: every center as seen)."""
    rank = np.arange(n)
    return {"as_seen": rank < 0, "alternate": rank % 2 == 1, "mirrored": rank >= 0}[spec.get("center_views", "as_seen")]


def run_viewed(session, spec, centers, feats, mask):
    """Boxes [N, 7] and scores [N, K] of one network call, each center seen as model.json
    `center_views` says (`mirror_rule`): a mirrored center's y offsets and center negated, its
    boxes mirrored back."""
    mirrored = mirrored_centers(spec, len(centers))
    feats, seen = feats.copy(), np.array(centers, np.float64)
    feats[mirrored, :, 1] *= -1
    seen[mirrored, 1] *= -1
    boxes, scores = boxes_and_scores(spec, seen, session.run(None, {"points": feats, "mask": mask}))
    back = np.repeat(mirrored, spec["anchors_per_center"])
    boxes[back, 1] *= -1
    boxes[back, 6] = wrap(-boxes[back, 6])
    return boxes, scores


def boxes_and_scores(spec, centers, outputs):
    """Decoded boxes [N, 7] and sigmoid scores [N, K] of one network call."""
    logits, residuals = outputs[0], outputs[1]
    anchors = np.concatenate([anchors_around(c, spec["anchors"]) for c in centers])
    boxes = decode(residuals.reshape(-1, 7).astype(np.float64), anchors)
    if spec.get("direction"):
        boxes[:, 6] = with_direction(boxes[:, 6], outputs[2].reshape(-1, 2), spec["direction"]["offset"])
    return boxes, 1.0 / (1.0 + np.exp(-logits.reshape(len(anchors), -1)))


def along_deg(points, slicing):
    """Azimuth from the sweep's start in the rotation sense, [0, 360) (SliceConfig::along_deg)."""
    az = np.degrees(np.arctan2(points[:, 1], points[:, 0]))
    start = slicing["start_azimuth_deg"]
    along = (start - az) if slicing["clockwise"] else (az - start)
    return np.minimum(np.mod(along, 360.0), np.nextafter(np.float32(360.0), np.float32(0.0)))


def slice_of(points, n, slicing):
    """Each point's slice of n, as starnet_data::sampling::SliceConfig::slice_of."""
    return np.minimum((along_deg(points, slicing) / (360.0 / n)).astype(int), n - 1)


def to_undelivered(points, slicing, delivered):
    """BEV distance to the azimuths not delivered once `delivered` degrees have been
    (starnet_data::sampling::distance_to_undelivered)."""
    if delivered >= 360.0:
        return np.full(len(points), np.inf)
    along, rho = along_deg(points, slicing), np.hypot(points[:, 0], points[:, 1])
    if delivered <= 0.0:
        return np.zeros(len(points))

    def ray(gap):
        return np.where(gap >= 90.0, rho, rho * np.sin(np.radians(np.minimum(gap, 90.0))))

    d = np.minimum(ray(delivered - along), ray(np.minimum(along, 360.0 - along)))
    return np.where(along >= delivered, 0.0, d)


def slicing_context(slicing):
    """The slice context; contracts exported before issue #51 spell it gather_previous."""
    if "context" in slicing:
        return slicing["context"]
    return "previous" if slicing["gather_previous"] else "own"


def slice_views(points, n, slicing, radius):
    """Per slice, in order: the points it reads and which of them may hold a center, as
    starnet_data::sampling::SweepSlicer for the contexts own, previous and arrived."""
    which = slice_of(points, n, slicing)
    for s in range(n):
        current = points[which == s]
        context = slicing_context(slicing)
        if context == "own" or (context == "previous" and s == 0):
            yield current, np.ones(len(current), bool)
        elif context == "previous":
            previous = points[which == s - 1]
            yield np.concatenate([previous, current]), np.r_[np.zeros(len(previous), bool), np.ones(len(current), bool)]
        elif context == "arrived":
            before, after = s * 360.0 / n, 360.0 if s + 1 == n else (s + 1) * 360.0 / n
            delivered = points[which <= s]
            was = to_undelivered(delivered, slicing, before)
            near = was < 2 * radius
            ready = (was < radius) & (to_undelivered(delivered, slicing, after) >= radius)
            yield delivered[near], ready[near]
        else:
            raise SystemExit(f"model.json: unknown streaming.slicing.context {context!r}")


def detect_streaming(session, spec, points, n, rng):
    """The sweep as n slices in order through the slice step, the LSTM state carried."""
    streaming = spec["streaming"]
    slicing = streaming["slicing"]
    h = streaming["lstm_hidden"]
    state = {"state_h": np.zeros((1, h), np.float32), "state_c": np.zeros((1, h), np.float32)}
    per = max(1, -(-spec["num_centers"] // n))
    pool_cfg = dict(spec["center_pool"], camera_frustum=False)  # a slice's pool has no frustum
    spaced = slicing.get("centers", "fresh") == "spaced" and n > 1
    if spaced:
        per = math.ceil(per * slicing["peak"])
    all_boxes, all_scores, used, placed = [], [], 0, np.zeros((0, 3), np.float32)
    steps = []  # (readable, centers or None), the last slice's further steps appended
    for s, (readable, ready) in enumerate(slice_views(points, n, slicing, spec["radius"])):
        rise = ground_rise(readable, spec.get("ground"))
        pool = np.intersect1d(center_pool(readable, pool_cfg, None, rise), np.flatnonzero(ready))
        if len(pool) == 0:
            steps.append((readable, None))
            continue
        xy = readable[pool, :2].astype(np.float64)
        if spaced:
            most = len(pool) if s + 1 == n else per
            chosen = pool[spaced_picks(xy, most, placed, slicing["spacing"], rng)]
        elif slicing.get("centers", "fresh") == "continued":
            chosen = pool[fps_bev(xy, per, rng, placed)]
        else:
            chosen = pool[fps_bev(xy, per, rng)]
        centers = centers_of(readable, chosen, spec, rise)
        placed = np.concatenate([placed, centers])
        steps.extend((readable, centers[i:i + per]) for i in range(0, max(len(centers), 1), per))
    for readable, centers in steps:
        if centers is None or len(centers) == 0:
            # No candidates: one padding center, invalid, so the LSTM sees a zero input.
            centers = np.zeros((1, 3), np.float32)
            feats = np.zeros((1, spec["num_points"], 4), np.float32)
            mask = np.zeros((1, spec["num_points"]), np.float32)
            valid = np.zeros(1, np.float32)
        else:
            feats, mask = gather(readable, centers, spec["num_points"], spec["radius"],
                                 spec.get("gather_metric", "ball"), rng)
            valid = np.ones(len(centers), np.float32)
        outputs = session.run(None, {"points": feats, "mask": mask, "center_valid": valid, **state})
        state = {"state_h": outputs[-2], "state_c": outputs[-1]}
        if valid.any():
            boxes, scores = boxes_and_scores(spec, centers, outputs)
            all_boxes.append(boxes)
            all_scores.append(scores)
            used += len(centers)
    k = len(spec["classes"])
    boxes = np.concatenate(all_boxes) if all_boxes else np.zeros((0, 7))
    scores = np.concatenate(all_scores) if all_scores else np.zeros((0, k))
    return boxes, scores, used


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--export", required=True, help="folder written by `starnet export`")
    ap.add_argument("--golden", action="store_true", help="check the export's golden files and exit")
    ap.add_argument("--input", help="a velodyne .bin file")
    ap.add_argument("--calib", help="its KITTI calib file")
    ap.add_argument("--out")
    ap.add_argument("--stream", type=int, nargs="?", const=0, metavar="N",
                    help="streaming LSTM export: N azimuth slices (default: model.json's eval_slices)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if args.golden:
        worst = check_golden(args.export)
        print(f"worst |diff| {worst:.2e}: {'ok' if worst <= 1e-4 else 'FAILED'}")
        raise SystemExit(0 if worst <= 1e-4 else 1)
    if not (args.input and args.calib and args.out):
        ap.error("--input, --calib and --out are needed to detect")

    spec = json.load(open(os.path.join(args.export, "model.json")))
    import onnxruntime as ort

    session = ort.InferenceSession(os.path.join(args.export, "model.onnx"))
    calib = read_calib(args.calib)
    rng = np.random.default_rng(args.seed)
    points = np.fromfile(args.input, np.float32).reshape(-1, 4)
    if (args.stream is not None) != bool(spec.get("streaming")):
        ap.error("--stream goes with a streaming LSTM export, and such an export needs it")

    if args.stream is not None:
        n = args.stream or spec["streaming"]["eval_slices"]
        boxes, scores, num_centers = detect_streaming(session, spec, points, n, rng)
    else:
        rise = ground_rise(points, spec.get("ground"))
        pool = center_pool(points, spec["center_pool"], calib, rise)
        centers, feats, mask = sample_and_gather(points, pool, spec["num_centers"], spec, rng, rise=rise)
        boxes, scores = run_viewed(session, spec, centers, feats, mask)
        num_centers = len(centers)
    lines = []
    for k, name in enumerate(spec["classes"]):
        kept = nms(boxes, scores[:, k], spec["nms_iou"][k], spec["nms_score"][k], spec["max_boxes"])
        candidates = np.flatnonzero(scores[:, k] >= spec["nms_score"][k])
        for i in kept:
            box = boxes[i]
            if spec.get("nms_vote_iou"):
                box = vote(boxes, scores[:, k], i, candidates, spec["nms_vote_iou"][k])
            line = kitti_line(name, box, scores[i, k], calib)
            if line:
                lines.append(line)
    os.makedirs(args.out, exist_ok=True)
    stem = os.path.splitext(os.path.basename(args.input))[0]
    with open(os.path.join(args.out, stem + ".txt"), "w") as f:
        f.write("".join(line + "\n" for line in lines))
    print(f"{stem}: {len(points)} points, {num_centers} centers, {len(lines)} boxes")


if __name__ == "__main__":
    main()
