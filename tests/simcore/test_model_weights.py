"""What a process reads from a weights file is kept until the file changes (`model_weights.cached_per_file`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from simcore.model_weights import cached_per_file


def test_a_file_is_read_once_and_again_after_it_is_rewritten(tmp_path: Path) -> None:
    reads: list[str] = []

    @cached_per_file(maxsize=4)
    def read(path: Path = tmp_path / "a.bin", suffix: str = "") -> str:
        reads.append(path.name)
        return path.read_text() + suffix

    first = tmp_path / "a.bin"
    first.write_text("one")
    assert read() == read(first) == "one" and reads == ["a.bin"]  # the default path is the same file
    assert read(first, suffix="!") == "one!" and len(reads) == 2  # other arguments are other entries
    first.write_text("three")  # rewritten in place: another size (and time)
    assert read(first) == "three" and len(reads) == 3
    with pytest.raises(FileNotFoundError):
        read(tmp_path / "missing.bin")  # a missing file reaches the reader, which says why
