#!/usr/bin/env python3
"""A KITTI-layout folder mirrored left to right in the LiDAR frame (y -> -y): how much a figure measured on a few real
frames depends on which side of the street its cars happen to stand (issue #47).

Training flips scenes the same way (`augment.flip_y`), so the mirrored folder is as fair a test as the original. The
points' y is negated; each label's box centre goes to the LiDAR frame through the frame's own calib, is mirrored (its
heading too) and comes back, so the box holds the mirrored returns (on `kitti-real-dev`, 25 of the 59,667 returns inside
its 220 Car boxes change sides: a box upright in the rectified camera frame cannot follow the camera's 0.6-degree roll
exactly); its 2D box is the projection of its corners by P2, clipped to a 1242 x 375 image. DontCare boxes are mirrored
about the principal point. The calib files and ImageSets are copied unchanged. The folder is written beside OUT and
renamed into place when complete; an existing OUT is refused.

    python3 scripts/mirror_kitti.py ../shared/kitti-real-dev /tmp/kitti-real-dev-mirrored
    starnet eval --checkpoint runs/quickstart/checkpoints/best --data /tmp/kitti-real-dev-mirrored --centers 512 --points 64

numpy only.
"""
import argparse
import math
import os
import shutil
import sys

import numpy as np

from box_errors import read_objects
from onnx_detect import IMAGE_H, IMAGE_W, image_extent
from onnx_detect import read_calib  # (P2, LiDAR -> rectified camera)


def image_box(p2, x, y, z, o, ry):
    """The projection of the box's eight corners (bottom centre x, y, z; camera frame), clipped to the image; None when
    a corner lies behind the camera."""
    extent = image_extent(p2, x, y, z, o["l"], o["w"], o["h"], ry)
    if extent is None:
        return None
    left, top, right, bottom = extent
    return [max(0.0, left), max(0.0, top), min(IMAGE_W - 1.0, right), min(IMAGE_H - 1.0, bottom)]


def mirrored_label(o, p2, lidar_to_cam, cam_to_lidar):
    """One label line of object `o` mirrored in the LiDAR frame."""
    if o["cls"] == "DontCare":
        left, top, right, bottom = o["box2d"]
        cx = p2[0, 2]
        return f"DontCare -1 -1 -10 {2 * cx - right:.2f} {top:.2f} {2 * cx - left:.2f} {bottom:.2f} -1 -1 -1 -1000 -1000 -1000 -10"
    # The box's centre, not its bottom (KITTI's location): the camera's up is not quite the LiDAR's z, and a mirror
    # flips the difference.
    centre = cam_to_lidar @ np.array([o["x"], o["y"] - o["h"] / 2, o["z"], 1.0])
    axis = cam_to_lidar[:3, :3] @ np.array([math.cos(o["ry"]), 0.0, -math.sin(o["ry"])])
    centre[1], axis[1] = -centre[1], -axis[1]
    x, y, z = (lidar_to_cam @ centre)[:3]
    y += o["h"] / 2
    a = lidar_to_cam[:3, :3] @ axis
    ry = math.atan2(-a[2], a[0])
    box = image_box(p2, x, y, z, o, ry) or o["box2d"]
    alpha = (ry - math.atan2(x, z) + math.pi) % (2 * math.pi) - math.pi
    return (f"{o['cls']} {o['trunc']:.2f} {int(o['occ'])} {alpha:.4f} {box[0]:.2f} {box[1]:.2f} {box[2]:.2f} "
            f"{box[3]:.2f} {o['h']:.2f} {o['w']:.2f} {o['l']:.2f} {x:.4f} {y:.4f} {z:.4f} {ry:.4f}")


def mirror_frame(src, dst, fid):
    """Points, calib and labels of one frame."""
    pts = np.fromfile(os.path.join(src, "training/velodyne", fid + ".bin"), dtype=np.float32).reshape(-1, 4).copy()
    pts[:, 1] *= -1
    pts.tofile(os.path.join(dst, "training/velodyne", fid + ".bin"))
    calib = os.path.join(src, "training/calib", fid + ".txt")
    shutil.copy(calib, os.path.join(dst, "training/calib", fid + ".txt"))
    p2, lidar_to_cam = read_calib(calib)
    cam_to_lidar = np.linalg.inv(lidar_to_cam)
    lines = [mirrored_label(o, p2, lidar_to_cam, cam_to_lidar) for o in read_objects(os.path.join(src, "training/label_2", fid + ".txt"))]
    with open(os.path.join(dst, "training/label_2", fid + ".txt"), "w") as f:
        f.write("".join(line + "\n" for line in lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("src", help="a KITTI-layout root (training/velodyne, label_2, calib; ImageSets)")
    ap.add_argument("out", help="the mirrored root to write (must not exist)")
    args = ap.parse_args()
    if os.path.exists(args.out):
        sys.exit(f"{args.out} exists: remove it or name another")
    tmp = args.out.rstrip("/") + ".partial"
    shutil.rmtree(tmp, ignore_errors=True)
    for d in ("training/velodyne", "training/label_2", "training/calib"):
        os.makedirs(os.path.join(tmp, d))
    shutil.copytree(os.path.join(args.src, "ImageSets"), os.path.join(tmp, "ImageSets"))
    ids = sorted(name[:-4] for name in os.listdir(os.path.join(args.src, "training/velodyne")) if name.endswith(".bin"))
    for fid in ids:
        mirror_frame(args.src, tmp, fid)
    os.rename(tmp, args.out)
    print(f"{len(ids)} frames mirrored into {args.out}")


if __name__ == "__main__":
    main()
