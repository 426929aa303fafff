"""Training from Python: the same model bytes as the lsnif program, the settings table as keyword
arguments, the progress callback, interruption."""

import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import lsnif
from conftest import BUNNY, read_off, run_cli


def test_arrays_train_the_same_model_bytes_as_the_file(tmp_path):
    cli_model = tmp_path / "cli.lsnif"
    run_cli("train", BUNNY, "-o", cli_model, "--tiny", "--quiet")
    vertices, faces = read_off(BUNNY)  # parsed here, not by the library
    mesh = lsnif.Mesh.from_arrays(vertices, faces, name=BUNNY.name)
    model = lsnif.train(mesh, tiny=True)
    py_model = tmp_path / "py.lsnif"
    model.save(str(py_model))
    assert py_model.read_bytes() == cli_model.read_bytes()
    assert model.to_bytes() == cli_model.read_bytes()
    assert lsnif.Model.from_bytes(cli_model.read_bytes()).to_bytes() == cli_model.read_bytes()


def test_float32_arrays_and_the_meshs_own_arrays_give_the_same_mesh(bunny):
    vertices, faces = read_off(BUNNY)
    again = lsnif.Mesh.from_arrays(vertices.astype(np.float32), faces.astype(np.int32), name=BUNNY.name)
    assert np.array_equal(again.vertices, bunny.vertices)
    assert np.array_equal(again.faces, bunny.faces)
    assert np.array_equal(again.normals, bunny.normals)


def test_settings_are_keyword_arguments_named_as_the_options(bunny):
    model = lsnif.train(bunny, tiny=True, steps=12, table_log2=[11, 12], width=16, seed=7)
    record = model.training_record
    assert record["settings"]["steps"] == 12
    assert record["settings"]["table-log2"] == [11, 12]
    assert record["settings"]["width"] == 16
    assert record["settings"]["seed"] == 7
    assert record["mesh"]["name"] == "bunny00.off"
    assert model.report["steps"] == 12
    info = model.info()
    assert info["hidden_width"] == 16
    assert model.memory["total"] == info["bytes"]["total"] > 0


def test_the_settings_table_is_the_tools(bunny):
    table = {s["name"]: s for s in lsnif.settings()}
    assert table["steps"]["default"] == 4000 and table["steps"]["min"] == 1
    assert table["hit"]["choices"] == ["segments", "aabb"]
    # One past each end of a range is refused, naming the setting.
    with pytest.raises(ValueError, match="voxels"):
        lsnif.train(bunny, tiny=True, voxels=table["voxels"]["max"] + 1)
    with pytest.raises(ValueError, match="steps"):
        lsnif.train(bunny, tiny=True, steps=0)


def test_progress_is_called_after_every_step(bunny):
    seen = []
    lsnif.train(bunny, tiny=True, progress=lambda step, steps, loss: seen.append((step, steps, loss)))
    assert [s[0] for s in seen] == list(range(1, 31))
    assert all(s[1] == 30 for s in seen)
    assert all(np.isfinite(s[2]) and s[2] > 0 for s in seen)


def test_an_exception_in_progress_stops_the_training_and_is_raised(bunny):
    class Stop(Exception):
        pass

    steps = []

    def progress(step, steps_total, loss):
        steps.append(step)
        if step == 3:
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        lsnif.train(bunny, tiny=True, progress=progress)
    assert steps == [1, 2, 3]


def test_a_time_budget_plans_the_steps_that_fit(bunny):
    model = lsnif.train(bunny, tiny=True, steps=1000000, time_budget=1.0)
    rep = model.report
    assert rep["seconds"] < 2.0, "the loop ran far past its budget"
    assert model.training_record["settings"]["steps"] == rep["planned_steps"]
    if rep["budget_cut"]:  # a host too busy to reach the first plan (step 8) in time
        assert rep["steps"] < rep["planned_steps"]
    else:
        assert 8 <= rep["planned_steps"] < 1000000
        assert rep["steps"] == rep["planned_steps"]


def test_ctrl_c_interrupts_a_long_training_cleanly(tmp_path):
    # A child trains for a million steps; at its first progress report it is sent SIGINT. The training
    # stops with KeyboardInterrupt (no crash), and the module still trains afterwards.
    script = tmp_path / "long.py"
    script.write_text(textwrap.dedent("""
        import sys, lsnif
        mesh = lsnif.Mesh.load(sys.argv[1])
        def progress(step, steps, loss):
            if step == 1:
                print("started", flush=True)
        try:
            lsnif.train(mesh, tiny=True, steps=1000000, progress=progress)
            print("not interrupted", flush=True)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
        model = lsnif.train(mesh, tiny=True, steps=5)
        print("trained again", model.report["steps"], flush=True)
    """))
    child = subprocess.Popen([sys.executable, str(script), str(BUNNY)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, env=os.environ.copy())
    assert child.stdout.readline().strip() == "started"
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=120)
    assert child.returncode == 0, err
    assert out.split("\n")[:2] == ["interrupted", "trained again 5"], out + err


def test_wrong_settings_raise_value_errors_naming_them(bunny):
    with pytest.raises(ValueError, match="no-such-setting"):
        lsnif.train(bunny, tiny=True, no_such_setting=1)
    with pytest.raises(ValueError, match="quality"):
        lsnif.train(bunny, quality="medium")
    with pytest.raises(ValueError, match="lr"):
        lsnif.train(bunny, tiny=True, lr=-1.0)
    with pytest.raises(ValueError, match="batch"):
        lsnif.train(bunny, tiny=True, batch="large")
    with pytest.raises(TypeError, match="batch"):
        lsnif.train(bunny, tiny=True, batch={"a": 1})
    with pytest.raises(ValueError, match="threads"):
        lsnif.train(bunny, tiny=True, threads=lsnif.MAX_THREADS + 1)
    with pytest.raises(ValueError, match="threads = -2 is out of range"):
        lsnif.train(bunny, tiny=True, threads=-2)
    with pytest.raises(TypeError, match="threads must be an int"):
        lsnif.train(bunny, tiny=True, threads=True)
    with pytest.raises(ValueError, match="time_budget"):
        lsnif.train(bunny, tiny=True, time_budget=-1.0)
    with pytest.raises(TypeError, match="progress"):
        lsnif.train(bunny, tiny=True, progress=5)
