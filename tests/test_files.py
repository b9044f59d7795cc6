"""Every output under one rule (docs/files-and-failures.md; ``reachavoid_env/files.py``,
``reachavoid/paths.py``): checked before any work, written atomically, through links and
into devices and FIFOs, an existing file replaced only with ``--force``, a file that
appears meanwhile kept, a failed write named in one line with nothing left behind.

Full-disk and read-only cases mount a small tmpfs (root only; skipped elsewhere), or run
in a private mount namespace (``unshare``).
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import threading

import pytest
from checks import BENCH, ROOT, SIMPLE, SIMPLE_2V1, command, fails_cleanly, in_namespace, needs_root

from reachavoid.cli import main
from reachavoid_env.files import atomic_write, private_folder
from solvers.hj.value import load_value_function


@pytest.fixture
def small_mount(tmp_path):
    """A 256 KiB tmpfs at ``tmp_path / "disk"`` (and a read-only one at ``.../ro``)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    disk, readonly = tmp_path / "disk", tmp_path / "ro"
    disk.mkdir(), readonly.mkdir()
    mounted = []
    for folder, options in ((disk, "size=256k"), (readonly, "size=64k,ro")):
        if subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)],
                          capture_output=True).returncode != 0:
            for done in mounted:
                subprocess.run(["umount", str(done)], check=False)
            pytest.skip("cannot mount a tmpfs here")
        mounted.append(folder)
    yield disk, readonly
    for folder in mounted:
        subprocess.run(["umount", "-l", str(folder)], check=False)


def test_solve_out_refuses_a_folder_of_other_files(tmp_path, capsys):
    notes = tmp_path / "notes.txt"
    notes.write_text("hi")
    fails_cleanly(capsys, ["solve", "--scenario", "paper_2v1", "--grid", "9", "--out",
                           str(tmp_path)], "exists and is not a value directory")
    assert notes.read_text() == "hi"


def test_full_disk_video_is_an_error_and_leaves_nothing(small_mount, capsys):
    disk, _ = small_mount
    (disk / "filler").write_bytes(b"x" * (200 * 1024))
    assert main(["play", "--scenario", "paper_2v1", *SIMPLE, "--video",
                 str(disk / "x.mp4")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "x.mp4" in err
    assert sorted(p.name for p in disk.iterdir()) == ["filler"]


def test_outputs_are_checked_before_any_work(tmp_path, capsys, monkeypatch):
    fails_cleanly(capsys, ["bench", "--config", "2v1", "--episodes", "1", "--defenders",
                           "greedy", "--csv", str(tmp_path / "nodir" / "x.csv")],
                  "--csv: folder")
    fails_cleanly(capsys, ["solve", "--plot", str(tmp_path / "nodir" / "x.png")],
                  "--plot: folder")
    a_file = tmp_path / "file"
    a_file.write_text("")
    fails_cleanly(capsys, ["paper", "--out", str(a_file)], "exists and is not a folder")
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(tmp_path)], "must end in")
    monkeypatch.setenv("REACHAVOID_CACHE_DIR", str(a_file))
    fails_cleanly(capsys, ["play", *SIMPLE], "is not a folder")


def test_read_only_folder_is_refused_before_the_work(small_mount, capsys):
    _, readonly = small_mount
    fails_cleanly(capsys, ["play", *SIMPLE, "--video", str(readonly / "x.mp4")],
                  "is not writable")
    fails_cleanly(capsys, ["paper", "--out", str(readonly / "results")],
                  "is not a writable folder")


def test_private_folder_checks_the_folders_it_creates(tmp_path):
    made = private_folder(tmp_path / "a" / "b")
    assert stat.S_IMODE((tmp_path / "a").stat().st_mode) == 0o700 and made.is_dir()
    (tmp_path / "open").mkdir()
    (tmp_path / "open").chmod(0o777)
    with pytest.raises(ValueError, match="others can write"):
        private_folder(tmp_path / "open" / "kernels")


def test_csv_through_a_link_writes_its_target(tmp_path, capsys):
    target, link = tmp_path / "real.csv", tmp_path / "link.csv"
    link.symlink_to(target)
    assert main([*BENCH, "--csv", str(link)]) == 0
    assert link.is_symlink() and target.read_text().startswith("cell,defenders,")


def test_video_through_a_dangling_link_writes_its_target(tmp_path, capsys):
    target, link = tmp_path / "real.mp4", tmp_path / "link.mp4"
    link.symlink_to(target)
    assert main(["play", *SIMPLE_2V1, "--video", str(link)]) == 0
    assert link.is_symlink() and target.stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.mp4", "real.mp4"]


def test_replacing_a_file_keeps_its_mode(tmp_path, capsys):
    path = tmp_path / "private.csv"
    path.write_text("old")
    path.chmod(0o600)
    assert main([*BENCH, "--csv", str(path), "--force"]) == 0
    assert stat.S_IMODE(path.stat().st_mode) == 0o600 and path.read_text() != "old"


def test_a_fifo_is_written_not_replaced(tmp_path, capsys):
    fifo = tmp_path / "rows.csv"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_text()))
    reader.start()
    assert main([*BENCH, "--csv", str(fifo)]) == 0
    reader.join(timeout=60)
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and received[0].startswith("cell,defenders,")


def test_a_character_device_is_written_not_replaced(tmp_path, capsys):
    needs_root()
    null = tmp_path / "null"
    os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    try:
        null.write_text("probe")
    except OSError:
        pytest.skip("device nodes cannot be opened here (nodev)")
    assert main([*BENCH, "--csv", str(null)]) == 0
    assert stat.S_ISCHR(null.lstat().st_mode)
    with atomic_write(null) as handle:
        handle.write("again")
    assert stat.S_ISCHR(null.lstat().st_mode)


def test_dash_is_standard_output_for_csv(capsys):
    assert main([*BENCH, "--csv", "-"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("cell,defenders,") and out.count("\n") == 3   # header + 2 episodes
    assert "capture rate" in err
    fails_cleanly(capsys, ["play", *SIMPLE_2V1, "--video", "-"], "must end in")


def test_dev_stdout_is_written_when_it_is_a_pipe():
    process = command(*BENCH, "--csv", "/dev/stdout", stdout=subprocess.PIPE)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0 and out.startswith("cell,defenders,"), err


@pytest.mark.parametrize("name", ["a{1}.mp4", "b{x}.mp4", "c{.mp4", "d{episode}.mp4"])
def test_braces_in_video_paths_are_kept(tmp_path, capsys, name):
    path = tmp_path / name
    assert main(["play", *SIMPLE_2V1, "--video", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["video"] == str(path)
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_full_disk_names_the_destination(tmp_path):
    disk = tmp_path / "disk"
    code = ("import sys; from solvers.hj import solve_1v1; import reachavoid_env as r;"
            "vf = solve_1v1(r.builtin_map('paper'), grid_points=15, cache=False,"
            " progress=False)\n"
            "try: vf.save(sys.argv[1])\n"
            "except OSError as err: print(err.filename, err.strerror)\n"
            "from reachavoid_env.files import atomic_write\n"
            "try:\n"
            "    with atomic_write(sys.argv[1] + '.csv') as f: f.write('x' * 10**6)\n"
            "except OSError as err: print(err.filename, err.strerror)")
    result = in_namespace(f"""
        mount --make-rprivate /
        mkdir -p {disk} && mount -t tmpfs -o size=64k tmpfs {disk}
        PYTHONPATH={ROOT} {sys.executable} -c "{code}" {disk / 'big.vf'}
        ls -A {disk}
    """, tmp_path)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith(str(disk / "big.vf"))
    assert lines[1].startswith(str(disk / "big.vf.csv")) and lines[2:] == []


def test_existing_outputs_are_replaced_only_with_force(tmp_path, capsys):
    video = tmp_path / "mine.mp4"
    video.write_bytes(b"precious")
    fails_cleanly(capsys, ["play", *SIMPLE_2V1, "--video", str(video)], "pass --force")
    assert video.read_bytes() == b"precious"
    assert main(["play", *SIMPLE_2V1, "--video", str(video), "--force"]) == 0
    assert video.read_bytes() != b"precious"


def test_paper_out_refuses_to_replace_a_users_table(tmp_path, capsys):
    (tmp_path / "table.json").write_text("my notes")
    fails_cleanly(capsys, ["paper", "--out", str(tmp_path), "--no-video"], "table.json")
    assert [p.name for p in tmp_path.iterdir()] == ["table.json"]


def test_solve_out_dot_in_an_empty_folder(tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["solve", "--scenario", "paper_2v1", "--grid", "9", "--out", "."]) == 0
    assert sorted(p.name for p in work.iterdir()) == ["meta.json", "value.npy"]
    assert load_value_function(work).grid.shape == (9, 9, 9, 9)


def test_too_long_names_are_refused_before_work(tmp_path, capsys):
    name = "v" * 240
    fails_cleanly(capsys, ["play", *SIMPLE_2V1, "--video", str(tmp_path / f"{name}.mp4")],
                  "too long")
    fails_cleanly(capsys, ["solve", "--grid", "9", "--out", str(tmp_path / name)],
                  "too long")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag", ["--csv", "--json", "--plot"])
def test_a_bench_output_that_appears_while_running_is_kept(tmp_path, monkeypatch, capsys,
                                                           flag):
    import reachavoid.commands as commands

    path = tmp_path / ("out.png" if flag == "--plot" else "out.txt")

    def meanwhile(*args, **kwargs):
        path.write_text("written by hand meanwhile")
        return run_suite(*args, **kwargs)

    run_suite = commands.run_suite
    monkeypatch.setattr(commands, "run_suite", meanwhile)
    err = fails_cleanly(capsys, [*BENCH, flag, str(path)], "appeared", status=1)
    assert str(path) in err and path.read_text() == "written by hand meanwhile"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.mark.parametrize("flag", ["--video", "--preview"])
def test_a_play_output_that_appears_while_running_is_kept(tmp_path, monkeypatch, capsys, flag):
    import reachavoid.play as play

    path = tmp_path / ("out.png" if flag == "--preview" else "out.gif")
    name = "first_frame" if flag == "--preview" else "run_episode"
    original = getattr(play, name)

    def meanwhile(*args, **kwargs):
        path.write_text("written by hand meanwhile")
        return original(*args, **kwargs)

    monkeypatch.setattr(play, name, meanwhile)
    fails_cleanly(capsys, ["play", *SIMPLE_2V1, flag, str(path)], "appeared", status=1)
    assert path.read_text() == "written by hand meanwhile"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    path.unlink()
    monkeypatch.undo()
    assert main(["play", *SIMPLE_2V1, flag, str(path)]) == 0 and path.stat().st_size > 100


@pytest.mark.parametrize("outputs", [("--csv", "same.out", "--json", "same.out"),
                                     ("--plot", "s.png", "--json", "s.png"),
                                     ("--csv", "-", "--json")])
def test_two_outputs_on_one_path_are_refused_before_work(tmp_path, monkeypatch, capsys,
                                                         outputs):
    monkeypatch.chdir(tmp_path)
    fails_cleanly(capsys, [*BENCH, *outputs], "give each output its own file")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_to_a_device_names_it(capsys):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    err = fails_cleanly(capsys, [*BENCH, "--csv", "/dev/full"], "No space left", status=1)
    assert "/dev/full" in err


@pytest.mark.parametrize("name", ["value.npy", "meta.json"])
def test_solve_refuses_a_plot_on_its_own_value_files(tmp_path, capsys, name):
    out = tmp_path / "D"
    out.mkdir()
    fails_cleanly(capsys, ["solve", "--game", "1v1", "--grid", "9", "--out", str(out),
                           "--plot", str(out / name), "--force"], "--plot:")
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("args", [[*BENCH, "--csv"], ["solve", "--grid", "9", "--plot"]])
def test_an_output_that_is_a_link_loop_is_refused_before_work(tmp_path, capsys, args):
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    fails_cleanly(capsys, [*args, str(loop)], "a loop")
    assert [p.name for p in tmp_path.iterdir()] == ["loop"] and loop.is_symlink()


def test_an_output_name_not_valid_in_the_locale_is_printed_as_given(tmp_path):
    done = subprocess.run([sys.executable, "-m", "reachavoid", *BENCH, "--csv", b"bad\xff.csv"],
                          capture_output=True, cwd=tmp_path, timeout=300,
                          env=dict(os.environ, PYTHONPATH=str(ROOT), LC_ALL="C.UTF-8",
                                   PYTHONIOENCODING="utf-8"))
    assert done.returncode == 0, done.stderr
    assert b"per-episode rows: bad\xff.csv\n" in done.stdout
    assert os.listdir(os.fsencode(tmp_path)) == [b"bad\xff.csv"]


def test_a_full_disk_while_kernels_compile_names_the_cache(tmp_path):
    cache = tmp_path / "disk" / "cache"
    run = (f"PYTHONPATH={ROOT} REACHAVOID_CACHE_DIR={cache} {sys.executable} -m reachavoid "
           "solve --scenario paper_1v1 --game 1v1 --grid 9")
    result = in_namespace(f"""
        mount --make-rprivate /
        mkdir -p {tmp_path / 'disk'} && mount -t tmpfs -o size=4m tmpfs {tmp_path / 'disk'}
        {run} > /dev/null
        rm -rf {cache}/kernels/__pycache__ {cache}/*.vf
        dd if=/dev/zero of={tmp_path / 'disk' / 'fill'} bs=4k 2> /dev/null || true
        {run} && exit 3
        exit 0
    """, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert f"{cache}: No space left on device" in result.stderr
