"""MPI decomposition (sectors, rings of sectors): results do not depend on the number of ranks (bit for bit),
springs migrate intact, checkpoints move between rank counts, failures never hang.

Each test launches ``mpiexec`` (the one beside sys.executable) on scripts in tests/mpi/; runs on
3 and 4 ranks oversubscribe the 2 cores, which is fine for correctness (never for timings).
"""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from helpers import couette_scene
from mpi_helpers import MPI_DIR, assert_same_state, dump_state, run_mpi

from pardem.input.scene_file import write_scene

QUICK = Path(__file__).parents[1] / "run_scripts" / "scenes" / "couette_quick.toml"


def fast_shear_scene(tmp_path, name="fast", output=None, averaging=None, **geometry):
    """A small dense cell, compressed in 0.1 s and sheared fast: many migrations per second."""
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 10.0, **geometry}
    path = tmp_path / f"{name}.toml"
    write_scene(couette_scene(counts=(260, 40), geometry=g, name=name, output=output,
                              averaging=averaging), path)
    return path


@pytest.mark.timeout(1800)
def test_pair_tables_are_bitwise_identical_on_1_and_2_ranks_and_change_the_run(tmp_path):
    """Pair laws for small-large, small-inner_ring and large-outer_ring: the partner numbers
    travel with migrants and ghosts, so 2 ranks give 1 rank's bits; the same cell without the
    tables ends elsewhere."""
    pairs = [{"species": ["small", "large"], "k_n": 700.0, "mu": 0.2},
             {"species": ["small", "inner_ring"], "mu": 0.8, "gamma_n": 0.3},
             {"species": ["large", "outer_ring"], "k_n": 500.0}]
    g = {"inner_radius": 0.05, "outer_radius": 0.09, "outer_start_radius": 0.11,
         "compression_time": 0.1, "omega_inner": 10.0}
    path = tmp_path / "pairs.toml"
    write_scene(couette_scene(counts=(260, 40), geometry=g, name="pairs",
                              contact={"pair": pairs}), path)
    steps = 8_000
    ref = dump_state(path, steps, tmp_path / "r1.npz", 1)
    got = dump_state(path, steps, tmp_path / "r2.npz", 2)
    assert got["migrated"] >= 5
    assert_same_state(ref, got, "2 ranks vs 1, with pair tables")
    plain = dump_state(fast_shear_scene(tmp_path), steps, tmp_path / "plain.npz", 1)
    assert not np.array_equal(plain["x"], ref["x"])


@pytest.mark.slow
@pytest.mark.timeout(2400)
def test_couette_quick_is_bitwise_identical_on_1_2_3_4_ranks(tmp_path):
    """Compression (2 s) and 1 s of shear: 69,000 steps, including migrations (each run may
    take minutes on a busy machine, 4 ranks oversubscribing 2 cores: 600 s per run)."""
    steps = 69_000
    ref = dump_state(QUICK, steps, tmp_path / "r1.npz", 1, timeout=600)
    assert ref["step"] == steps and ref["migrated"] == 0
    assert np.abs(ref["pair_hist"]).max() > 0
    for n in (2, 3, 4):
        got = dump_state(QUICK, steps, tmp_path / f"r{n}.npz", n, timeout=600)
        assert got["migrated"] >= 20, f"{n} ranks: only {got['migrated']} migrations"
        # each rank moves only the wall disks near its sector, and no pair needs another one
        assert got["idle_walls"] > 0 and got["idle_wall_pairs"] == 0
        assert_same_state(ref, got, f"{n} ranks vs 1")
    assert ref["idle_walls"] == 0


@pytest.mark.timeout(2400)  # six runs, each with its own time limit that names the run
def test_fast_shear_with_many_migrations_is_bitwise_identical(tmp_path):
    """On 2 and 3 ranks with the ghosts refreshed through shared memory (the default on one
    node with a core per rank; by messages when oversubscribed), on 2 ranks also by messages,
    once with a shared window that has to grow, once switching between shared memory and
    messages from exchange to exchange (a limit inside the range of refresh sizes), and once
    with no spare rows, so that exchanges that bring migrants store the new layout through
    larger arrays instead of moving the rows in place."""
    scene = fast_shear_scene(tmp_path)
    steps = 20_000
    ref = dump_state(scene, steps, tmp_path / "r1.npz", 1)
    cores = len(os.sched_getaffinity(0))
    messages = {"PARDEM_HALO": "messages"}
    # (ranks, options, environment, shared windows made if the ranks have a core each)
    check = ("--check-lists",)
    for n, extra, env, windows in ((2, check, None, 1), (3, check, None, 1),
                                   (2, (), messages, 0), (2, ("--grow-window",), None, 2),
                                   (2, ("--shared-limit", "78"), None, 1),
                                   (2, ("--no-room",), None, 1)):
        label = f"{n} ranks {extra} {env or ''} vs 1"
        got = dump_state(scene, steps, tmp_path / f"r{n}.npz", n, *extra, env=env)
        assert got["migrated"] >= 100, f"{label}: only {got['migrated']} migrations"
        # most builds keep the ghosts (exchange_due); the lists stay complete at every one
        assert 100 < got["exchanges"] < got["rebuilds"] // 2, label
        if extra == check:
            assert got["lists_checked"] == got["rebuilds"], label
        assert got["shared_windows"] == (windows if n <= cores else 0), label
        if extra == ("--no-room",):
            assert got["regrown"] >= 10, f"{label}: {got['regrown']} exchanges grew the arrays"
        if extra[:1] == ("--shared-limit",):
            assert 0 < got["shared_exchanges"] < got["exchanges"] - 20, label
        assert_same_state(ref, got, label)


@pytest.mark.timeout(1800)
def test_rings_of_sectors_are_bitwise_identical_to_one_rank(tmp_path):
    """Cut into 2 rings x 2 sectors on 4 ranks (ghosts across both kinds of edge, re-cut at
    nearly every other exchange, so that wall disks a rank did not move come near its domain
    and are touched at once) and into 3 rings of one sector each on 3 ranks: the same bits as
    one rank, with migrations across the rings' boundaries and every pair listed."""
    scene = fast_shear_scene(tmp_path)
    steps = 12_000
    ref = dump_state(scene, steps, tmp_path / "r1.npz", 1)
    for n, cut, threshold in ((4, "2x2", "0"), (3, "3x1", "0.1")):
        label = f"{n} ranks cut {cut} vs 1"
        got = dump_state(scene, steps, tmp_path / f"r{n}.npz", n, "--cut", cut, "--check-lists",
                         "--balance-threshold", threshold)
        assert got["rings"] == int(cut[0]), label
        if threshold == "0":
            assert got["rebalanced"] >= 10, f"{label}: re-cut {got['rebalanced']} times"
        assert got["migrated"] >= 100, f"{label}: only {got['migrated']} migrations"
        assert got["lists_checked"] == got["rebuilds"] > 100, label
        assert got["idle_walls"] > 0 and got["idle_wall_pairs"] == 0, label
        assert_same_state(ref, got, label)


@pytest.mark.slow
@pytest.mark.timeout(5400)
def test_30k_cell_is_bitwise_identical_on_1_2_4_8_16_ranks_as_sectors_and_rings(tmp_path):
    """B scaled to 30,096 disks, compressed and sheared on one rank to 1.2 s (27,567 steps),
    then 20,000 more steps: on one rank without a stop, and from the 1.2 s checkpoint on 2
    (the automatic cut), 4 (2 x 2), 8 (2 x 4) and 16 ranks (4 x 4, and sectors), each with
    migrations (oversubscribed: minutes per run)."""
    scene = Path(__file__).parents[1] / "run_scripts" / "scenes" / "couette_B_30k.toml"
    start, steps = 27_567, 47_567
    ckpt = tmp_path / "c.h5"
    ref = dump_state(scene, steps, tmp_path / "r1.npz", 1, "--checkpoint-at", str(start),
                     str(ckpt), timeout=2400)
    for n, cut, rings in ((2, "auto", 1), (4, "2x2", 2), (8, "2x4", 2), (16, "4x4", 4),
                          (16, "sectors", 1)):
        label = f"{n} ranks cut {cut} vs 1"
        got = dump_state(scene, steps, tmp_path / f"r{n}.npz", n, "--restart", str(ckpt),
                         "--cut", cut, timeout=1800)
        assert got["rings"] == rings, label
        assert got["migrated"] >= 50, f"{label}: only {got['migrated']} migrations"
        assert_same_state(ref, got, label)


def test_loaded_springs_migrate_intact(tmp_path):
    """A particle with >= 2 loaded contacts is moved across a sector edge: its contacts'
    forces and springs are the same on both ranks before and after, and the run continues
    bit for bit like the serial one (checks inside tests/mpi/migrate_loaded.py)."""
    scene = fast_shear_scene(tmp_path)
    settle, after = 5000, 2000
    out = tmp_path / "moved.npz"
    run_mpi([str(MPI_DIR / "migrate_loaded.py"), str(scene), str(settle), str(after), str(out)], 2)
    with np.load(out) as f:
        moved = {k: f[k] for k in f.files}
    assert moved["loaded_contacts"] >= 2
    ref = dump_state(scene, settle + after, tmp_path / "serial.npz", 1)
    assert_same_state(ref, moved, "forced migration on 2 ranks vs 1 rank")


def test_checkpoint_from_2_ranks_continues_bitwise_on_1_and_3(tmp_path):
    scene = fast_shear_scene(tmp_path)
    ckpt = tmp_path / "c.h5"
    ref = dump_state(scene, 8000, tmp_path / "r2.npz", 2, "--checkpoint-at", "4000", str(ckpt))
    for n in (1, 3):
        got = dump_state(scene, 8000, tmp_path / f"from_ckpt_{n}.npz", n, "--restart", str(ckpt))
        assert_same_state(ref, got, f"restart on {n} ranks vs uninterrupted 2 ranks")


def test_a_branch_on_2_ranks_from_a_1_rank_preparation_equals_the_1_rank_branch(tmp_path):
    """Prepared on one rank (compressed, then sheared); branched at another mu and omega, on 1
    and on 2 ranks: the same bits (the branch's first forces are computed, not read)."""
    scene = fast_shear_scene(tmp_path)
    ckpt = tmp_path / "prepared.h5"
    dump_state(scene, 3000, tmp_path / "prep.npz", 1, "--checkpoint-at", "2500", str(ckpt))
    branch = tmp_path / "branch.toml"
    write_scene(couette_scene(counts=(260, 40), name="branch", contact={"mu": 0.2},
                              geometry={"inner_radius": 0.05, "outer_radius": 0.09,
                                        "outer_start_radius": 0.11, "compression_time": 0.1,
                                        "omega_inner": 5.0}), branch)
    ref = dump_state(branch, 5000, tmp_path / "b1.npz", 1, "--from", str(ckpt))
    got = dump_state(branch, 5000, tmp_path / "b2.npz", 2, "--from", str(ckpt))
    assert got["migrated"] > 0 and np.abs(ref["pair_hist"]).max() > 0
    assert_same_state(ref, got, "branch on 2 ranks vs 1")


def test_a_failing_rank_aborts_the_job_quickly(tmp_path):
    scene = fast_shear_scene(tmp_path)
    proc = run_mpi([str(MPI_DIR / "fail_on_rank.py"), str(scene), str(tmp_path / "out")], 2,
                   timeout=600, check=False, module=False)
    assert proc.returncode != 0
    assert "rank 1 failed" in proc.stderr and "injected failure on rank 1" in proc.stderr


def test_too_many_ranks_is_refused_with_a_clear_message(tmp_path):
    # 8 sectors of a 10 mm inner ring are 7.9 mm wide there, less than the 9.7 mm ghost width
    scene = fast_shear_scene(tmp_path, inner_radius=0.01, outer_radius=0.07,
                             outer_start_radius=0.1)
    proc = run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / "o"),
                    "--cut", "sectors"], 8, timeout=600, check=False, module=False)
    assert proc.returncode != 0
    assert "too many for this cell" in proc.stderr and "use at most" in proc.stderr


def test_more_ranks_than_cores_warn_once_with_the_counts(tmp_path):
    """4 ranks on this machine's cores (fewer than 4): one warning, from rank 0, naming both
    counts (docs/warnings.md); the cores are those the test process may run on."""
    cores = len(os.sched_getaffinity(0))
    if cores >= 4:
        pytest.skip(f"{cores} cores: 4 ranks are not oversubscribed here")
    scene = fast_shear_scene(tmp_path)
    done = run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / "o"),
                    "--end", "0.01", "--quiet"], 4, module=False)
    said = f"pardem: warning: 4 ranks share {cores} cores on one node"
    assert done.stderr.count("ranks share") == 1 and said in done.stderr, done.stderr
    assert f"at most {cores} ranks per node" in done.stderr
    log = (tmp_path / "o" / "log.txt").read_text()
    assert log.count(f"warning: 4 ranks share {cores} cores") == 1


def test_a_2_rank_warmup_leaves_nothing_for_a_2_rank_run_to_compile(tmp_path):
    """`mpiexec -n 2 pardem warmup SCENE` compiles what a 2-rank run of the scene calls: the
    run then loads every kernel from the cache (numba reports each kernel it saves)."""
    scene = fast_shear_scene(tmp_path, output={"snapshot_interval": 0.01})
    warm = run_mpi(["-m", "pardem.cli", "warmup", str(scene)], 2, module=False)
    assert "kernels ready for 2 ranks" in warm.stdout
    done = run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / "run"),
                    "--end", "0.03", "--quiet"], 2, module=False,
                   env={"NUMBA_DEBUG_CACHE": "1"})
    assert "[cache] data loaded" in done.stdout
    assert "[cache] data saved" not in done.stdout, done.stdout


def test_kernels_compiled_ahead_have_the_signatures_of_their_calls(tmp_path):
    """compile_ahead splits a 2-rank run's cold compile between the ranks by signatures made
    from the arguments of the calls that follow: every rank then holds exactly one compiled
    version of each of those kernels (a wrong signature would leave two on the rank that
    compiled it ahead, and cost a second compile)."""
    scene = fast_shear_scene(tmp_path, averaging={"start": 0.0, "end": 1.0,
                                                  "sample_interval": 0.1})
    done = run_mpi([str(MPI_DIR / "compile_ahead_check.py"), str(scene)], 2)
    every = json.loads(done.stdout.strip().splitlines()[-1])
    assert len(every) == 2 and {
        "send_rows", "receive_rows", "peer_offsets", "contact_forces", "every_pair",
        "selected_pairs", "ring_contacts", "accumulate",
        "touching_pairs", "touching_rings", "kinetic_energy", "max_overlap_ratio",
        "largest_move", "owners", "halo_buffers"} <= set(every[1]["versions"])
    assert every[0]["ahead"] and every[1]["ahead"]
    for rank, mine in enumerate(every):
        assert all(mine["versions"][k] == 1 for k in mine["ahead"]), f"rank {rank}: {mine}"
        assert all(n <= 1 for n in mine["versions"].values()), f"rank {rank}: {mine}"


def test_pardem_run_on_2_ranks_writes_the_serial_snapshots(tmp_path):
    """`mpiexec -n 2 pardem run` (the README's main job form) writes, sorted by id, the same
    particle and contact data as a serial run, and the same checkpoint."""
    import h5py

    import pardem
    from pardem.cli import main

    scene = fast_shear_scene(tmp_path, output={"snapshot_interval": 0.1})
    assert main(["run", str(scene), "--out", str(tmp_path / "serial"), "--end", "0.3",
                 "--quiet"]) == 0
    run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / "mpi"), "--end",
             "0.3", "--quiet"], 2, module=False)
    serial = list(pardem.read_snapshots(tmp_path / "serial"))
    parallel = list(pardem.read_snapshots(tmp_path / "mpi"))
    assert len(serial) == len(parallel) >= 3
    for a, b in zip(serial, parallel):
        assert a["time"] == b["time"]
        for key in ("id", "kind", "position", "velocity", "omega", "force", "torque",
                    "coordination"):
            np.testing.assert_array_equal(a[key], b[key], key)
        for key in a["contacts"]:
            np.testing.assert_array_equal(a["contacts"][key], b["contacts"][key], key)
    assert set(np.unique(parallel[-1]["rank"])) == {-1, 0, 1}  # wall disks, rank 0, rank 1
    # the stage breakdown shows the time spent waiting in the per-step exchange, a part of the
    # step loop's time (MPI_Wtime around the waits, summed over every neighbour-list plan)
    log = (tmp_path / "mpi" / "log.txt").read_text().splitlines()
    step = next(float(x.split()[1]) for x in log if x.strip().startswith("forces+integration"))
    wait = next(float(x.split()[5]) for x in log if "of which waiting on neighbours" in x)
    assert 0.0 <= wait < step
    serial_log = (tmp_path / "serial" / "log.txt").read_text()
    assert "forces+integration" in serial_log and "waiting" not in serial_log
    # the files themselves: every dataset but the owning rank, and the XDMF indexes
    files = sorted(p.name for p in (tmp_path / "serial" / "snapshots").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "mpi" / "snapshots").iterdir())
    n_datasets = 0
    for file in files:
        with h5py.File(tmp_path / "serial" / "snapshots" / file) as s, \
                h5py.File(tmp_path / "mpi" / "snapshots" / file) as p:
            names, others = [], []
            s.visit(names.append)
            p.visit(others.append)
            assert sorted(names) == sorted(others)
            assert dict(s.attrs) == dict(p.attrs)
            datasets = [n for n in names if isinstance(s[n], h5py.Dataset)]
            n_datasets += len(datasets)
            for name in datasets:
                if name != "rank":
                    np.testing.assert_array_equal(s[name][()], p[name][()], name)
    assert n_datasets > 50
    for name in ("particles.xdmf", "contacts.xdmf"):
        assert (tmp_path / "serial" / name).read_text() == (tmp_path / "mpi" / name).read_text()
    with h5py.File(tmp_path / "serial" / "checkpoint.h5") as s, \
            h5py.File(tmp_path / "mpi" / "checkpoint.h5") as p:
        for key in ("x", "v", "omega", "pair_lo", "pair_hi", "pair_hist"):
            np.testing.assert_array_equal(s[key][()], p[key][()], key)


def assert_rings_continued(whole: dict, cut: dict, kept: int) -> None:
    """A restarted run's rings.h5 (``cut``) against the uninterrupted run's: the same sample
    times, the first ``kept`` samples (the checkpoint's) and the ring loads the same bits (the
    loads are the same bits on any number of ranks), the later sums within 1e-12 of each
    column's largest value (a restart cuts the annulus anew: the ranks sum other particles)."""
    assert np.abs(whole["sums"]).max() > 0
    np.testing.assert_array_equal(cut["times"], whole["times"])
    np.testing.assert_array_equal(cut["sums"][:kept], whole["sums"][:kept])
    np.testing.assert_array_equal(cut["ring_loads_samples"], whole["ring_loads_samples"])
    scale = np.abs(whole["sums"]).max(axis=(0, 1))
    assert np.all(np.abs(cut["sums"] - whole["sums"]) <= 1e-12 * scale + 1e-300)


def test_averages_of_a_run_restarted_on_2_ranks_equal_the_uninterrupted_runs(tmp_path):
    """A serial run stopped inside the averaging window and continued from its checkpoint on
    2 ranks writes the uninterrupted serial run's ring averages: the samples before the
    checkpoint come from it bit for bit, the later ones agree to 1e-12 relative (summation
    order), and so do the fields; the loads on the rings are the same bits throughout."""
    from averaging.io import read_rings
    from pardem.cli import main

    scene = fast_shear_scene(tmp_path, averaging={"start": 0.15, "end": 0.3,
                                                  "sample_interval": 0.025,
                                                  "ring_width": 0.9275e-3},
                             output={"checkpoint_interval": 0.1})
    assert main(["run", str(scene), "--out", str(tmp_path / "whole"), "--end", "0.3",
                 "--quiet"]) == 0
    assert main(["run", str(scene), "--out", str(tmp_path / "cut"), "--end", "0.2",
                 "--quiet"]) == 0
    run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / "cut"), "--end",
             "0.3", "--restart", str(tmp_path / "cut" / "checkpoint.h5"), "--quiet"], 2,
            module=False)
    whole, cut = read_rings(tmp_path / "whole"), read_rings(tmp_path / "cut")
    assert whole["times"].size == 7
    assert_rings_continued(whole, cut, kept=3)  # 0.15, 0.175, 0.2 s
    for key in ("nu", "v_phi", "sigma_rr", "F_rr", "mu_c"):
        np.testing.assert_allclose(cut[key], whole[key], rtol=1e-9, atol=0, err_msg=key)
    assert "continuing the ring averages from its 3 samples" in (
        tmp_path / "cut" / "log.txt").read_text()


def test_ring_sums_do_not_depend_on_the_number_of_ranks(tmp_path):
    """In-situ averaging: every rank sums its owned particles, one Allreduce per sample; the
    totals of 1, 2 and 3 ranks agree to 1e-12 relative (only the summation order differs).
    The loads on the rings are the same bits on any number of ranks."""
    from averaging.boundary import LOADS
    from averaging.io import read_rings
    from averaging.fields import COL

    scene = fast_shear_scene(tmp_path, averaging={"start": 0.15, "end": 0.3,
                                                  "sample_interval": 0.05,
                                                  "ring_width": 0.9275e-3})
    sums, torques, loads = {}, {}, {}
    for n in (1, 2, 3):
        run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / f"r{n}"),
                 "--end", "0.31", "--quiet"], n, module=False)
        rings = read_rings(tmp_path / f"r{n}")
        sums[n], torques[n] = rings["sums"], rings["inner_torque_samples"]
        loads[n] = rings["ring_loads_samples"]
    assert sums[1].shape[0] == 4  # samples at 0.15, 0.2, 0.25, 0.3 s
    assert np.abs(sums[1][:, :, COL["stress_rr"]]).max() > 0  # the cell is loaded
    scale = np.abs(sums[1]).max(axis=(0, 1))  # per column
    for n in (2, 3):
        np.testing.assert_allclose(sums[n], sums[1], rtol=0, atol=1e-12 * scale.max())
        assert np.all(np.abs(sums[n] - sums[1]) <= 1e-12 * scale + 1e-300)
        # the loads on the rings: every contact's share, added correctly rounded (fsum)
        np.testing.assert_array_equal(loads[n], loads[1])
        np.testing.assert_array_equal(torques[n], torques[1])
    assert np.all(torques[1] > 0)  # the ring drives the packing
    outer = loads[1][:, LOADS.index("outer_torque")]
    assert np.all(outer < 0) and np.all(loads[1][:, LOADS.index("outer_radial_force")] > 0)


@pytest.mark.timeout(900)
def test_a_restart_on_two_ranks_keeps_the_samples_up_to_its_checkpoint(tmp_path):
    """2 ranks, stopped inside the averaging window and restarted on 2 (docs/running.md):
    ``assert_rings_continued``, and the particles end the same bits."""
    import h5py

    from averaging.io import read_rings

    scene = fast_shear_scene(tmp_path, averaging={"start": 0.11, "end": 0.15,
                                                  "sample_interval": 0.01,
                                                  "ring_width": 0.9275e-3},
                             output={"checkpoint_interval": 0.1, "snapshot_interval": 1.0})

    def run(out: str, end: str, *extra: str) -> None:
        run_mpi(["-m", "pardem.cli", "run", str(scene), "--out", str(tmp_path / out), "--end",
                 end, "--quiet", *extra], 2, module=False)

    run("whole", "0.15")
    run("cut", "0.13")
    run("cut", "0.15", "--restart", str(tmp_path / "cut"))
    whole, cut = read_rings(tmp_path / "whole"), read_rings(tmp_path / "cut")
    assert whole["times"].size == 5
    assert_rings_continued(whole, cut, kept=3)  # 0.11, 0.12, 0.13 s
    with h5py.File(tmp_path / "whole" / "checkpoint.h5") as a, \
            h5py.File(tmp_path / "cut" / "checkpoint.h5") as b:
        for key in ("x", "v", "omega", "pair_hist"):
            np.testing.assert_array_equal(a[key][()], b[key][()], key)
