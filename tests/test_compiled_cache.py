"""numba's cached machine code is used only when it was compiled from the sources as they are."""
from drakeslip.compiled import STAMP, clear_when_sources_change


def make_package(tmp_path):
    package = tmp_path / "pkg"
    (package / "__pycache__").mkdir(parents=True)
    (package / "core.py").write_text("X = 1\n")
    return package


def test_cached_code_from_other_sources_is_deleted_and_kept_once_they_match(tmp_path):
    package = make_package(tmp_path)
    compiled = [package / "__pycache__" / "core.f-1.py311.nbi", package / "__pycache__" / "core.f-1.py311.1.nbc"]
    for path in compiled:
        path.write_bytes(b"old machine code")
    assert clear_when_sources_change(package, [package])          # no stamp: nothing proves what it came from
    assert not any(path.exists() for path in compiled)
    assert (package / "__pycache__" / STAMP).exists()
    compiled[0].write_bytes(b"fresh machine code")
    assert not clear_when_sources_change(package, [package])      # same sources: the cache stays
    assert compiled[0].exists()


def test_a_change_in_another_package_clears_the_dependent_cache(tmp_path):
    package, other = make_package(tmp_path), tmp_path / "dependency"
    other.mkdir()
    (other / "step.py").write_text("def step(): return 1\n")
    clear_when_sources_change(package, [package, other])
    compiled = package / "__pycache__" / "core.f-1.py311.nbi"
    compiled.write_bytes(b"machine code inlining step()")
    (other / "step.py").write_text("def step(): return 2\n")
    assert clear_when_sources_change(package, [package, other])
    assert not compiled.exists()
