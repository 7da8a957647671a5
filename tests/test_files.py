import pytest, os
from drakeslip.files import atomic_write

def test_atomic_write_replaces_only_on_success(tmp_path):
    path = tmp_path / "sub" / "result.json"
    with atomic_write(path, "w") as f:
        f.write("first")
    assert path.read_text() == "first"
    with pytest.raises(RuntimeError):
        with atomic_write(path, "w") as f:
            f.write("half")
            raise RuntimeError("killed")
    assert path.read_text() == "first"
    assert os.listdir(path.parent) == ["result.json"]
