import pytest, os
from drakeslip.jobs.files import atomic_write

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


def test_jsonl_cache_skips_a_line_cut_short_by_a_kill(tmp_path):
    from drakeslip.jobs.files import append_jsonl, read_jsonl_cache

    path = tmp_path / "cache.jsonl"
    with open(path, "a") as sink:
        append_jsonl(sink, {"key": "a", "result": 1})
        append_jsonl(sink, {"key": "b"})            # missing a field
        sink.write('{"key": "c", "res')             # killed mid-write
    assert read_jsonl_cache(path, lambda e: e["key"], lambda e: e["result"]) == {"a": 1}
    assert read_jsonl_cache(tmp_path / "none.jsonl", lambda e: e, lambda e: e) == {}


def test_an_entry_appended_after_a_cut_short_line_is_kept(tmp_path):
    from drakeslip.jobs.files import append_jsonl, open_jsonl_cache, read_jsonl_cache

    path = tmp_path / "new" / "cache.jsonl"                 # the folder is created
    with open_jsonl_cache(path) as sink:
        append_jsonl(sink, {"key": "a", "result": 1})
        sink.write('{"key": "c", "res')                      # killed mid-write
    with open_jsonl_cache(path) as sink:                     # the resumed job
        append_jsonl(sink, {"key": "d", "result": 4})
    assert read_jsonl_cache(path, lambda e: e["key"], lambda e: e["result"]) == {"a": 1, "d": 4}
