"""StarNet LiDAR 3D object detection on numpy points, and KITTI / Waymo-style metrics.

Frames and boxes: points are ``[x, y, z(, intensity)]`` in the LiDAR frame (metres, x forward,
y left, z up); a box is ``[x, y, z, dx, dy, dz, heading]``, ``(x, y, z)`` its centre and
``heading`` its yaw about z.

>>> import starnet
>>> det = starnet.Detector("models/quickstart")
>>> result = det.detect(starnet.read_cloud("000000.bin"))
>>> result.boxes.shape, result.scores, result.classes
"""

from . import metrics
from ._starnet import Detections, Detector, StarnetError, read_cloud

__all__ = ["Detector", "Detections", "StarnetError", "read_cloud", "metrics"]
