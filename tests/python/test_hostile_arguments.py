# The Python module under hostile arguments (issue 49): every public function and method called
# with None, wrong types, empty, misshapen and large arrays in place of each argument in turn
# raises a Python exception or returns, and never takes the interpreter down (run in a child
# process, whose exit status is the oracle); a typo never unblocks a no-fly zone; data without a
# CRS are refused by the library; Ctrl-C stops a long plan() within half a second.
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import dsmplan

SAMPLE = os.path.join(os.environ.get("DSMPLAN_DATA_DIR", "data"), "nrw-dom1", "nrw_dom1_crop500m_1m.tif")

# A 60 m x 60 m block city in EPSG:25832, small enough that every call on it is quick.
SMALL_CITY = textwrap.dedent("""
    import numpy as np
    import dsmplan
    heights = np.full((60, 60), 110.0, dtype=np.float32)
    heights[20:40, 20:40] = 130.0
    transform = (1.0, 0.0, 356300.0, 0.0, -1.0, 5699760.0)
    dsm = dsmplan.Dsm(heights, transform, "EPSG:25832")
    mesh = dsmplan.simplify(dsm)
    waypoints = np.array([[356305.0, 5699755.0, 115.0], [356355.0, 5699705.0, 115.0]])
""")

FUZZ = SMALL_CITY + textwrap.dedent("""
    import os, sys, tempfile, time
    flight = dsmplan.plan(mesh, waypoints, dsm=dsm)
    folder = tempfile.mkdtemp()
    out = lambda name: os.path.join(folder, name)
    hostile = [None, 0, -1, 1e308, float("nan"), "", "\\x00", "\\x1b[31m", [], {}, (), object(), b"bytes",
               np.zeros((0, 3)), np.zeros((0,)), np.zeros((3,)), np.zeros((2, 2, 2)), np.full((2, 3), np.nan),
               np.zeros((2, 3), dtype=object), np.zeros((50000, 3)), [np.zeros((2, 3))] * 300,
               np.zeros((1, 1), dtype=np.float32), dsm, mesh, flight]
    # Each public call with arguments that work, by position then by keyword.
    calls = [
        (dsmplan.read_dsm, [SAMPLE], {}),
        (dsmplan.Dsm, [heights, transform, "EPSG:25832"], {"nodata": None}),
        (dsmplan.mesh, [dsm], {"zstep": 0.1}),
        (dsmplan.simplify, [dsm], {"max_error": 0.4, "conservative": True, "delaunay": False}),
        (dsmplan.plan, [mesh, waypoints], {"dsm": dsm, "dtm": None, "safety": 2.0, "max_agl": 120.0, "spacing": 20.0,
                                           "planner": "prm", "mission": False, "no_fly": [], "no_fly_blocking": None,
                                           "snap": 0.0, "waypoint_heights": "crs"}),
        (dsmplan.plan_routes, [mesh, [waypoints]], {"dsm": dsm, "safety": 2.0, "planner": "prm",
                                                    "no_fly_blocking": None, "waypoint_heights": "crs"}),
        (dsmplan.render, [dsm, out("r.png")], {"paths": flight, "waypoints": waypoints, "zoom": 1.0,
                                                "no_fly_blocking": None}),
        (dsmplan.profile, [dsm, flight, out("p.png")], {"dtm": None, "width": 300, "height": 200,
                                                        "no_fly_blocking": None}),
        (dsmplan.grid, [SAMPLE, 50.0], {"crs": "", "fusion": "median", "classes": []}),
        (dsm.write, [out("d.tif")], {}),
        (mesh.write, [out("m.ply")], {}),
        (flight.write, [out("f.csv")], {"format": "", "firmware": "generic", "altitude_frame": "relative"}),
        (dsmplan.stereo, [None], {"cameras": None, "res": 1.0, "pairs": "auto"}),
    ]
    raised = returned = 0
    for function, args, keywords in calls:
        name = getattr(function, "__qualname__", str(function))
        started = time.monotonic()
        for position in range(len(args)):
            for value in hostile:
                given = list(args)
                given[position] = value
                try:
                    function(*given, **keywords)
                    returned += 1
                except Exception:  # a Python exception is the answer; a crash ends this process
                    raised += 1
        for key in keywords:
            for value in hostile:
                try:
                    function(*args, **dict(keywords, **{key: value}))
                    returned += 1
                except Exception:
                    raised += 1
        print(name, "%.2f s" % (time.monotonic() - started), file=sys.stderr)  # where the time goes
    print("raised", raised, "returned", returned)
""")


def run_python(script, timeout=600):
    script = "SAMPLE = %r\n" % SAMPLE + script
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))


def test_no_argument_crashes_any_public_function():
    result = run_python(FUZZ)
    assert result.returncode == 0, (result.returncode, result.stdout[-2000:], result.stderr[-2000:])
    raised, returned = (int(n) for n in result.stdout.split()[1::2])
    assert raised > 500 and returned > 0  # the fuzz reached the checks, and the calls still work


def test_none_for_the_mesh_is_a_type_error_not_a_crash():
    heights = np.full((20, 20), 100.0, dtype=np.float32)
    waypoints = np.array([[356301.0, 5699701.0, 110.0], [356315.0, 5699715.0, 110.0]])
    for call in (lambda: dsmplan.plan(None, waypoints), lambda: dsmplan.plan_routes(None, [waypoints]),
                 lambda: dsmplan.simplify(None), lambda: dsmplan.mesh(None),
                 lambda: dsmplan.Dsm(None, (1, 0, 356300, 0, -1, 5699720), "EPSG:25832")):
        with pytest.raises(TypeError):
            call()
    dsm = dsmplan.Dsm(heights, (1, 0, 356300, 0, -1, 5699720), "EPSG:25832")
    with pytest.raises(TypeError):
        dsmplan.plan(dsmplan.simplify(dsm), None)


def test_a_typo_in_the_blocking_restrictions_is_refused_not_unblocking():
    heights = np.full((40, 40), 100.0, dtype=np.float32)
    dsm = dsmplan.Dsm(heights, (1, 0, 356300, 0, -1, 5699740), "EPSG:25832")
    mesh = dsmplan.simplify(dsm)
    waypoints = np.array([[356305.0, 5699735.0, 110.0], [356335.0, 5699705.0, 110.0]])
    for value, said in ((["PROHIBTED"], "did you mean PROHIBITED?"), (["prohibited"], "did you mean PROHIBITED?"),
                        ([""], "got ''"), ([], "names no restriction"), (["NONE", "PROHIBITED"], "stands alone")):
        for call in (lambda: dsmplan.plan(mesh, waypoints, no_fly_blocking=value),
                     lambda: dsmplan.plan_routes(mesh, [waypoints], no_fly_blocking=value),
                     lambda: dsmplan.render(dsm, "/nonexistent/never.png", no_fly_blocking=value)):
            with pytest.raises(dsmplan.ArgumentError, match="^no_fly_blocking: .*" + said.replace("?", r"\?")):
                call()
    assert dsmplan.plan(mesh, waypoints, no_fly_blocking=["NONE"]).path.shape[1] == 3  # on purpose: allowed


def test_data_without_a_crs_or_in_feet_are_refused_by_the_library():
    heights = np.full((40, 40), 100.0, dtype=np.float32)
    waypoints = np.array([[356305.0, 5699735.0, 110.0], [356335.0, 5699705.0, 110.0]])
    bare = dsmplan.Dsm(heights, (1, 0, 356300, 0, -1, 5699740), "")
    with pytest.raises(dsmplan.InputError, match="has no CRS"):
        dsmplan.plan(dsmplan.simplify(bare), waypoints)
    with pytest.raises(dsmplan.InputError, match="has no CRS"):
        dsmplan.plan_routes(dsmplan.simplify(bare), [waypoints])
    # NAD83 / New York Long Island (ftUS): 2 ft planned as 2 m before the CLI's check.
    feet = dsmplan.Dsm(heights, (1, 0, 1000000, 0, -1, 200040), "EPSG:2263")
    with pytest.raises(dsmplan.Error, match="foot"):
        dsmplan.plan(dsmplan.simplify(feet), np.array([[1000005.0, 200035, 110], [1000035, 200005, 110]]))


def test_ctrl_c_stops_a_long_plan_within_half_a_second():
    # A roadmap of 3 m spacing over the real crop: 1.1 million samples, each joined to every other
    # within 34.5 m: minutes of work in one call (the paper's 20 m takes a fraction of a second).
    script = textwrap.dedent(f"""
        import sys, time
        import numpy as np
        import dsmplan
        mesh = dsmplan.simplify(dsmplan.read_dsm({SAMPLE!r}))
        waypoints = np.array([[356320.0, 5699270.0, 130.0], [356560.0, 5699500.0, 145.0]])
        print("planning", flush=True)
        try:
            dsmplan.plan(mesh, waypoints, spacing=3.0)
            print("returned", flush=True)
        except KeyboardInterrupt:
            print("interrupted", time.monotonic(), flush=True)
    """)
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    try:
        assert child.stdout.readline().strip() == "planning"
        time.sleep(1.5)  # well into the work
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=60)
    finally:
        child.kill()
    words = out.split()
    assert words and words[0] == "interrupted", (out, err)
    assert float(words[1]) - sent < 0.5, f"KeyboardInterrupt came {float(words[1]) - sent:.2f} s after Ctrl-C"
