"""Output files: atomic writes, output paths checked before a run, failures agreed by every
rank (core/files.py)."""

from pathlib import Path

import pytest
from roughfriction.errors import InputError
from roughfriction.files import (
    agreed,
    atomic_write,
    check_results_file,
    check_writable_directory,
    check_writable_file,
)


class Ranks:
    """Stands in for a communicator: this rank's value, and those of the other ranks."""

    def __init__(self, rank: int, others: dict):
        self.rank, self.others = rank, others

    def allgather(self, value):
        return [self.others.get(rank, value) if rank != self.rank else value
                for rank in range(1 + len(self.others))]


def test_a_failure_on_another_rank_stops_this_one_with_its_message():
    assert agreed(Ranks(0, {1: None}), lambda: 7) == 7
    with pytest.raises(InputError, match="^cannot read case file x.toml$"):
        agreed(Ranks(0, {1: "cannot read case file x.toml"}), lambda: 7)


def test_a_failure_here_is_one_line_on_every_rank(tmp_path):
    def fail():
        raise FileNotFoundError(2, "No such file or directory", str(tmp_path / "gone"))

    with pytest.raises(InputError, match="^cannot write .*gone: No such file or directory$"):
        agreed(Ranks(1, {0: None}), fail)


def test_unwritable_outputs_are_found_without_creating_anything(tmp_path):
    (tmp_path / "a_file").write_text("")
    with pytest.raises(InputError, match="a_file is not a directory"):
        check_writable_file(tmp_path / "a_file" / "run.h5")
    with pytest.raises(InputError, match="a_file is not a directory"):
        check_writable_directory(tmp_path / "a_file" / "fields")
    with pytest.raises(InputError, match="is a directory"):
        check_writable_file(tmp_path)
    check_writable_file(tmp_path / "run.h5")
    check_writable_directory(tmp_path / "fields")
    check_writable_directory(tmp_path)
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a_file"]


def test_a_missing_folder_is_refused_not_created(tmp_path):
    with pytest.raises(InputError, match=r"folder .*nonexistent/dir does not exist"):
        check_writable_file(tmp_path / "nonexistent" / "dir" / "x.h5")
    with pytest.raises(InputError, match=r"folder .*nonexistent does not exist"):
        check_writable_directory(tmp_path / "nonexistent" / "fields")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="needs /proc")
def test_a_folder_that_takes_no_file_is_found_although_its_mode_says_writable():
    with pytest.raises(InputError, match="^cannot write /proc/nope.h5: "):
        check_writable_file(Path("/proc/nope.h5"))
    with pytest.raises(InputError, match="^cannot write in /proc/fields: "):
        check_writable_directory(Path("/proc/fields"))


def test_a_results_file_must_be_named_as_hdf5(tmp_path):
    with pytest.raises(InputError, match=r"res.csv: an HDF5 file is written, name it res.h5"):
        check_results_file(tmp_path / "res.csv")
    check_results_file(tmp_path / "res.h5")
    check_results_file(tmp_path / "res.HDF5")


def test_a_failed_write_leaves_the_previous_file(tmp_path):
    path = tmp_path / "table.csv"
    path.write_text("old\n")

    def half_then_fail(temporary):
        with open(temporary, "w") as file:
            file.write("half")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        atomic_write(path, half_then_fail)
    assert path.read_text() == "old\n"
    assert [one.name for one in tmp_path.iterdir()] == ["table.csv"]
