"""`starnet.metrics` against `starnet eval --results` on the real development street."""

import json
import subprocess
import sys

import numpy as np
import pytest

import starnet
from conftest import run


@pytest.fixture(scope="module")
def scored(tmp_path_factory, starnet_bin, model_dir, kitti_real_dev):
    """The quickstart's detections of the street's 51 frames, and `starnet eval --results`' eval.json."""
    detections = tmp_path_factory.mktemp("detections")
    run(starnet_bin, "detect", "--model", model_dir, "--input", kitti_real_dev / "training" / "velodyne", "--out", detections)
    out = tmp_path_factory.mktemp("eval")
    run(starnet_bin, "eval", "--results", detections, "--data", kitti_real_dev, "--split", "val", "--out", out)
    return detections, json.loads((out / "eval.json").read_text())


def test_a_result_folder_scores_as_the_cli_does(scored, kitti_real_dev):
    detections, want = scored
    got = starnet.metrics.score(kitti_real_dev, detections, split="val")
    assert got == want
    assert got["frames"] == 51
    car = got["classes"][0]
    assert car["class"] == "Car" and 0.0 < car["three_d"][1]["r40"] <= 100.0
    assert starnet.metrics.kitti(kitti_real_dev, detections) == want["classes"]
    assert starnet.metrics.waymo(kitti_real_dev, detections) == want["waymo"]


def test_kitti_result_lines_score_as_the_json(scored, kitti_real_dev):
    detections, want = scored
    got = starnet.metrics.score(kitti_real_dev, detections, format="kitti")
    assert got["classes"] == want["classes"]
    assert starnet.metrics.kitti(kitti_real_dev, detections, format="kitti") == want["classes"]


def test_arrays_score_as_their_files(scored, kitti_real_dev):
    detections, want = scored
    results = {}
    for path in sorted(detections.glob("*.json")):
        sweep = json.loads(path.read_text())
        results[sweep["id"]] = {
            "boxes": np.array([d["box"] for d in sweep["detections"]], dtype=np.float64).reshape(-1, 7),
            "scores": [d["score"] for d in sweep["detections"]],
            "classes": [d["class"] for d in sweep["detections"]],
        }
    assert starnet.metrics.score(kitti_real_dev, results) == want
    assert starnet.metrics.kitti(kitti_real_dev, results) == want["classes"]


def test_detector_results_score_directly(model_dir, kitti_real_dev, scored):
    _, want = scored
    det = starnet.Detector(model_dir)
    ids = (kitti_real_dev / "ImageSets" / "val.txt").read_text().split()
    velodyne = kitti_real_dev / "training" / "velodyne"
    results = {}
    for i, frame in enumerate(ids):
        calib = kitti_real_dev / "training" / "calib" / f"{frame}.txt"
        results[frame] = det.detect(starnet.read_cloud(velodyne / f"{frame}.bin"), calib=calib, index=i, id=frame)
    assert starnet.metrics.score(kitti_real_dev, results) == want


def test_incomplete_or_malformed_results_are_refused(kitti_real_dev):
    empty = {"boxes": np.zeros((0, 7)), "scores": [], "classes": []}
    ids = (kitti_real_dev / "ImageSets" / "val.txt").read_text().split()
    results = {i: empty for i in ids[1:]}
    with pytest.raises(ValueError, match=ids[0]):
        starnet.metrics.score(kitti_real_dev, results, classes=["Car"])
    results[ids[0]] = {"boxes": np.zeros((2, 6)), "scores": [0.5, 0.5], "classes": ["Car", "Car"]}
    with pytest.raises(ValueError, match=r"\[M, 7\]"):
        starnet.metrics.score(kitti_real_dev, results, classes=["Car"])
    results[ids[0]] = {"boxes": np.zeros((1, 7)), "scores": [0.5], "classes": ["Lorry"]}
    with pytest.raises(ValueError, match="Lorry"):
        starnet.metrics.score(kitti_real_dev, results, classes=["Car"])
    results[ids[0]] = empty
    results["999999"] = empty
    with pytest.raises(ValueError, match="999999"):
        starnet.metrics.score(kitti_real_dev, results, classes=["Car"])


def test_a_missing_result_file_names_it(tmp_path, kitti_real_dev):
    with pytest.raises((FileNotFoundError, starnet.StarnetError), match="000"):
        starnet.metrics.score(kitti_real_dev, tmp_path, format="detect")


def test_the_readmes_example_runs(tmp_path, kitti_real_dev):
    # The README's Python block, verbatim but for its paths: run from a folder that has
    # models/quickstart and ../shared/kitti-real-dev as the README assumes.
    from conftest import REPO

    text = (REPO / "README.md").read_text()
    block = text.split("## From Python", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    work = tmp_path / "repo"
    (work / "models").mkdir(parents=True)
    (work / "models" / "quickstart").symlink_to(REPO / "models" / "quickstart")
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "kitti-real-dev").symlink_to(kitti_real_dev)
    done = subprocess.run([sys.executable, "-c", block], cwd=work, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("Car 3D AP R40 moderate"), done.stdout
    assert len(list((work / "runs" / "python-results").glob("*.txt"))) == 51
