"""The YAML reader shared by scenes and study configs (ced.problem.yaml_files): its limits."""
import pytest

from ced.problem.errors import SceneError
from ced.problem.scene import load_scene
from ced.problem.yaml_files import MAX_DEPTH, MAX_FILE_BYTES, MAX_NODES, check_structure, load_yaml
from ced.study.config import load_config, validate_config


def test_dialects(tmp_path):
    # Scenes read YAML 1.2 numbers and booleans; configs read them as Snakemake does (1.1).
    path = tmp_path / "d.yaml"
    path.write_text("a: 1e-3\nb: yes\nc: 0o17\n")
    assert load_yaml(path, "<scene>", "1.2") == {"a": 0.001, "b": "yes", "c": "0o17"}
    assert load_yaml(path, "<config>", "1.1") == {"a": "1e-3", "b": True, "c": "0o17"}


@pytest.mark.parametrize("dialect", ["1.1", "1.2"])
def test_duplicate_keys_are_refused_in_both_dialects(tmp_path, dialect):
    path = tmp_path / "dup.yaml"
    path.write_text("a: 1\nb: {c: 1, c: 2}\n")
    with pytest.raises(SceneError, match="found duplicate key 'c'"):
        load_yaml(path, "<config>", dialect)


def test_a_device_or_huge_file_is_refused_without_reading_it_all(tmp_path):
    with pytest.raises(SceneError, match=f"larger than {MAX_FILE_BYTES} bytes"):
        load_scene("/dev/zero")
    big = tmp_path / "big.yaml"
    big.write_text("# " + "x" * MAX_FILE_BYTES + "\n")
    with pytest.raises(SceneError, match="larger than"):
        load_config(big)


def test_nul_bytes_are_refused(tmp_path):
    path = tmp_path / "nul.yaml"
    path.write_bytes(b"a: 1\x00\n")
    with pytest.raises(SceneError, match="NUL"):
        load_scene(path)


def test_structure_limits_hold_for_mappings_given_directly():
    # A mapping handed to ced (not read from a file) meets the same limits: deep nesting and
    # shared sub-lists that expand beyond MAX_NODES values are refused, before any walk that
    # recurses or copies.
    deep = {}
    node = deep
    for _ in range(MAX_DEPTH + 5):
        node["a"] = {}
        node = node["a"]
    with pytest.raises(SceneError, match="nested more than"):
        load_scene({"mechanism": {"type": "single_link", "length": 0.5}, "name": deep})
    shared = [0.1] * 10
    for _ in range(5):
        shared = [shared] * 10   # 10^6 values, a few hundred objects
    with pytest.raises(SceneError, match=f"more than {MAX_NODES} values"):
        validate_config({"study": "x", "grids": {"four_bar": {"ground": 0.5, "crank": shared}}})
    check_structure({"a": [1, 2, {"b": "c"}]}, "<scene>")  # small documents pass


def test_very_deep_yaml_is_refused_not_a_traceback(tmp_path):
    path = tmp_path / "deep.yaml"
    path.write_text("a: " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(SceneError, match="nested more than"):
        load_config(path)
