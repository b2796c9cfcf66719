"""`starnet.Detector` against `starnet detect` on the same export and the same real sweeps."""

import json

import numpy as np
import pytest

import starnet
from conftest import run


def sweeps(root):
    return sorted((root / "training" / "velodyne").glob("*.bin"))


@pytest.fixture(scope="module")
def detect_folder(tmp_path_factory, starnet_bin, model_dir, kitti_sample):
    out = tmp_path_factory.mktemp("detect")
    run(starnet_bin, "detect", "--model", model_dir, "--input", kitti_sample / "training" / "velodyne", "--out", out)
    return out


def test_boxes_scores_and_result_lines_equal_starnet_detects(detect_folder, model_dir, kitti_sample):
    det = starnet.Detector(model_dir)
    files = sweeps(kitti_sample)
    assert len(files) == 3
    found = 0
    for i, f in enumerate(files):
        calib = kitti_sample / "training" / "calib" / f"{f.stem}.txt"
        got = det.detect(starnet.read_cloud(f), calib=calib, index=i, id=f.stem)
        want = json.loads((detect_folder / f"{f.stem}.json").read_text())
        boxes = np.array([d["box"] for d in want["detections"]], dtype=np.float32).reshape(-1, 7)
        scores = np.array([d["score"] for d in want["detections"]], dtype=np.float32)
        assert got.boxes.shape == boxes.shape and got.boxes.dtype == np.float32
        np.testing.assert_allclose(got.boxes, boxes, rtol=0, atol=1e-5)
        np.testing.assert_allclose(got.scores, scores, rtol=0, atol=1e-5)
        assert got.classes == [d["class"] for d in want["detections"]]
        assert got.num_points == want["num_points"]
        assert got.kitti_lines == (detect_folder / f"{f.stem}.txt").read_text().splitlines()
        found += len(got)
    assert found > 0, "the quickstart finds cars on the sample frames"


def test_detect_many_indexes_sweeps_as_a_folder_does(model_dir, kitti_sample):
    det = starnet.Detector(model_dir)
    files = sweeps(kitti_sample)
    clouds = [starnet.read_cloud(f) for f in files]
    many = det.detect_many(clouds)
    for i, (cloud, got) in enumerate(zip(clouds, many)):
        one = det.detect(cloud, index=i)
        np.testing.assert_array_equal(got.boxes, one.boxes)
        assert got.kitti_lines is None, "no calibration, no KITTI lines"


def test_float64_and_non_contiguous_points_give_the_same_boxes(model_dir, kitti_sample):
    det = starnet.Detector(model_dir)
    cloud = starnet.read_cloud(sweeps(kitti_sample)[0])
    base = det.detect(cloud)
    wide = np.zeros((cloud.shape[0], 8), dtype=np.float64)
    wide[:, ::2] = cloud
    again = det.detect(wide[:, ::2])
    np.testing.assert_array_equal(base.boxes, again.boxes)


def test_the_budget_is_the_callers(model_dir):
    det = starnet.Detector(model_dir, centers=128, points=16)
    assert (det.centers, det.points, det.classes) == (128, 16, ["Car"])
    default = starnet.Detector(model_dir)
    assert default.gflop_per_frame > det.gflop_per_frame > 0


def test_xyz_points_detect_with_a_geometry_only_model(model_dir, kitti_sample):
    # The quickstart ignores intensity: [N, 3] and [N, 4] give the same boxes.
    det = starnet.Detector(model_dir)
    cloud = starnet.read_cloud(sweeps(kitti_sample)[1])
    np.testing.assert_array_equal(det.detect(cloud).boxes, det.detect(cloud[:, :3]).boxes)


def test_read_cloud_reads_every_format(tmp_path, kitti_sample, starnet_bin):
    cloud = starnet.read_cloud(sweeps(kitti_sample)[0])
    assert cloud.dtype == np.float32 and cloud.shape[1] == 4
    raw = np.fromfile(sweeps(kitti_sample)[0], dtype=np.float32).reshape(-1, 4)
    np.testing.assert_array_equal(cloud, raw)
    np.save(tmp_path / "xyz.npy", raw[:, :3])
    np.testing.assert_array_equal(starnet.read_cloud(tmp_path / "xyz.npy"), raw[:, :3])
    np.save(tmp_path / "xyzi.npy", raw)
    np.testing.assert_array_equal(starnet.read_cloud(tmp_path / "xyzi.npy"), raw)
