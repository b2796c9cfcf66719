"""Bad input is a Python exception carrying the library's message."""

import numpy as np
import pytest

import starnet


def test_a_missing_model_names_its_path(tmp_path):
    with pytest.raises((FileNotFoundError, starnet.StarnetError), match="no-such-model"):
        starnet.Detector(tmp_path / "no-such-model")


def test_a_corrupt_export_is_a_starnet_error(tmp_path):
    (tmp_path / "model.safetensors").write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{not json}")
    with pytest.raises(starnet.StarnetError, match="model.safetensors"):
        starnet.Detector(tmp_path)


def test_bad_shapes_are_value_errors(model_dir):
    det = starnet.Detector(model_dir)
    with pytest.raises(ValueError, match=r"\[N, 3\]"):
        det.detect(np.zeros((10, 5), dtype=np.float32))
    with pytest.raises(ValueError, match=r"\[N, 3\]"):
        det.detect(np.zeros(12, dtype=np.float32))
    with pytest.raises(ValueError, match="positive"):
        starnet.Detector(model_dir, centers=0)


def test_an_infinite_coordinate_names_the_row(model_dir):
    points = np.zeros((5, 4), dtype=np.float32)
    points[3, 1] = np.inf
    with pytest.raises(starnet.StarnetError, match="3"):
        starnet.Detector(model_dir).detect(points)


def test_a_truncated_bin_names_the_file(tmp_path):
    path = tmp_path / "cut.bin"
    path.write_bytes(np.zeros(4 * 4 + 2, dtype=np.uint8).tobytes())
    with pytest.raises(starnet.StarnetError, match="cut.bin"):
        starnet.read_cloud(path)


def test_a_missing_cloud_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="absent.bin"):
        starnet.read_cloud(tmp_path / "absent.bin")


def test_a_missing_calib_is_file_not_found(model_dir, tmp_path):
    with pytest.raises(FileNotFoundError, match="nocalib.txt"):
        starnet.Detector(model_dir).detect(np.zeros((5, 4), dtype=np.float32), calib=tmp_path / "nocalib.txt")
