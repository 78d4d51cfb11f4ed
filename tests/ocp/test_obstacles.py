"""The obstacle OCP: separating lines between the bodies and the scene, and an NMPC that keeps to them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from hitchpark import VehicleTrailer
from hitchpark.control import NMPCSettings
from hitchpark.control.nmpc import COLD_ROUNDS, FullNMPC
from hitchpark.control.receding import NLPProblem
from hitchpark.maneuver.scenario import builtin_scenario
from hitchpark.model.collision import clearance
from hitchpark.model.geometry import body_corners
from hitchpark.model.plant import Measurement
from hitchpark.model.scene import Area, Obstacle, Scene
from hitchpark.model.state import Pose, State, from_goal_frame, to_goal_frame
from hitchpark.ocp import obstacles as obstacles_module
from hitchpark.ocp import separating as separating_module
from hitchpark.ocp.obstacles import REACH_M, ClearanceConstraints, convex_pieces
from hitchpark.ocp.separating import separating_lines, separating_lines_numpy

coordinate = st.floats(-4.0, 4.0)


def _box(x: float, y: float, yaw: float, length: float, width: float) -> np.ndarray:
    local = np.array([[-length, -width], [length, -width], [length, width], [-length, width]]) / 2
    c, s = math.cos(yaw), math.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + [x, y]


def _free(ends: np.ndarray) -> np.ndarray:
    d = ends[:, 1] - ends[:, 0]
    return np.column_stack([d[:, 1], -d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]


@settings(max_examples=200, deadline=None)
@given(
    st.tuples(coordinate, coordinate, st.floats(-math.pi, math.pi), st.floats(0.2, 4.0), st.floats(0.2, 2.5)),
    st.lists(coordinate, min_size=4, max_size=4),
    st.booleans(),
)
def test_the_line_gives_the_exact_distance_and_separates(box, seg, polygon_body):
    """Against Shapely: the distance of a convex body to a segment, and a line through the nearest points that
    has the whole body on one side and the segment on the other (or, overlapping, distance 0)."""
    ends = np.array(seg, dtype=float).reshape(1, 2, 2)
    if np.hypot(*(ends[0, 1] - ends[0, 0])) < 1e-3:
        return
    points = _box(*box) if polygon_body else _box(*box)[:2]
    body = shapely.Polygon(points) if polygon_body else shapely.LineString(points)
    distance, n, h = separating_lines(points[None], ends, _free(ends))
    true = shapely.distance(body, shapely.LineString(ends[0]))
    assert distance[0, 0] == pytest.approx(true, abs=1e-9)
    assert np.hypot(*n[0, 0]) == pytest.approx(1.0)
    assert max(ends[0] @ n[0, 0]) == pytest.approx(h[0, 0])
    if true > 1e-9:
        assert min(points @ n[0, 0]) - h[0, 0] == pytest.approx(true, abs=1e-9)  # tight where it is drawn


# Coordinates on a coarse grid as well, so that corners fall on segments, ends on edges and gaps tie.
grid_or_not = st.one_of(coordinate, st.integers(-3, 3).map(float))


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_the_compiled_lines_are_numpys_to_the_last_bit(shared_jit_cache, data):
    """Compiled (separating_lines.c), the lines are NumPy's bit for bit: bodies as segments and polygons,
    one set of segments for every body or each its own, segments of zero length, ties of the nearest pair."""
    assert separating_module._kernel(True, str(shared_jit_cache[0])) is not None  # the compiled code, not NumPy again
    k, c, m = data.draw(st.integers(1, 4)), data.draw(st.sampled_from([2, 4])), data.draw(st.integers(1, 5))
    each_own = data.draw(st.booleans())

    def array(*shape: int) -> np.ndarray:
        size = int(np.prod(shape))
        return np.array(data.draw(st.lists(grid_or_not, min_size=size, max_size=size)), dtype=float).reshape(shape)

    points = array(k, c, 2)
    ends = array(k, m, 2, 2) if each_own else array(m, 2, 2)
    free = array(*ends.shape[:-2], 2)
    compiled = separating_lines(points, ends, free)
    reference = separating_lines_numpy(points, ends, free)
    for got, want in zip(compiled, reference, strict=True):
        assert got.shape == want.shape
        assert np.array_equal(got, want, equal_nan=True)


def test_the_compiled_lines_refuse_shapes_that_do_not_fit(shared_jit_cache):
    """Where NumPy would not broadcast, the compiled call raises rather than read past an array."""
    points, ends = np.zeros((3, 4, 2)), np.zeros((2, 5, 2, 2))
    with pytest.raises(ValueError, match="do not fit 3 bodies"):
        separating_lines(points, ends, np.zeros((2, 5, 2)))
    with pytest.raises(ValueError, match="bodies must be"):
        separating_lines(np.zeros((3, 1, 2)), ends[0], np.zeros((5, 2)))


def test_where_the_compiler_refuses_the_lines_are_numpys(jit_cache, monkeypatch):
    """A C compiler that fails leaves the NumPy lines: the same answers, nothing left half-built."""
    monkeypatch.setenv("CC", "false")  # found on the path, compiles nothing
    assert separating_module._kernel(True, str(jit_cache[0])) is None
    points, ends = np.array([[[0.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]]), np.array([[[-1.0, 0.0], [2.0, 0.0]]])
    distance, n, h = separating_lines(points, ends, np.array([[0.0, 1.0]]))
    assert distance[0, 0] == 1.0 and np.array_equal(n[0, 0], [0.0, 1.0]) and h[0, 0] == 0.0
    assert not list(jit_cache[0].glob("separating_lines-c-*/*.so"))


def test_a_scenes_lines_are_the_same_compiled_or_not(shared_jit_cache, monkeypatch):
    """The NMPC's parameters among obstacles, drawn with the compiled lines and with NumPy's, are equal."""
    lines = ClearanceConstraints(VEHICLE, 3)
    lines.use(SCENE, 0.25)
    goal, rng = Pose(0.5, -0.2, 0.05), np.random.default_rng(11)
    start = np.array([1.0, 0.0, 0.0, 0.0])
    plans = [start + np.cumsum(rng.normal(0.0, [0.4, 0.2, 0.05, 0.05], (11, 4)), axis=0) for _ in range(8)]
    assert obstacles_module._kernel(True, str(shared_jit_cache[0])) is not None  # the compiled parameters
    compiled = [lines.parameters(goal, plan, keep_warm=True) for plan in plans]
    monkeypatch.setattr(separating_module, "_kernel", lambda *_: None)
    for plan, got in zip(plans, compiled, strict=True):
        assert np.array_equal(got, lines.parameters_numpy(goal, plan, keep_warm=True))  # NumPy all through
    assert any(np.any(got[2::3] != -1.0) for got in compiled)  # lines were drawn, not only unused slots


@pytest.mark.parametrize("name", ["driveway", "loading_dock", "curb_parallel", "boat_ramp"])
def test_the_compiled_parameters_are_numpys_to_the_last_bit(name, shared_jit_cache):
    """clearance_lines.c (in-process where it compiles, and in the exported package) draws each step's lines as
    the NumPy does, bit for bit: random warm starts about the scene's start and goal, anchored or not, keeping
    the warm start's lines or not, on scenes of convex and non-convex obstacles and the ground outside an area."""
    sc = builtin_scenario(name)
    lines = ClearanceConstraints(sc.vehicle, 3)
    lines.use(sc.scene, 0.23)
    rng = np.random.default_rng(5)
    start = np.array([*to_goal_frame(sc.goal, sc.start.x, sc.start.y, sc.start.yaw), sc.start.hitch])
    drawn = 0
    for trial in range(24):
        near_goal = np.array([rng.uniform(0.0, 8.0), rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 0.5), 0.0])
        base = (start if trial % 2 else near_goal) + rng.normal(0.0, [1.0, 1.0, 0.3, 0.2])
        walk = base + np.cumsum(rng.normal(0.0, [0.3, 0.3, 0.05, 0.05], (11, 4)), 0)
        plan = np.column_stack([walk, np.zeros((11, 2))])
        for anchored, keep_warm in ((True, False), (True, True), (False, False)):
            got = lines.parameters(sc.goal, plan, anchored, keep_warm)
            assert np.array_equal(got, lines.parameters_numpy(sc.goal, plan, anchored, keep_warm)), (trial, anchored)
            drawn += int(np.sum(got[2::3] != -1.0))
    assert drawn > 1000  # lines drawn, not only unused slots


def _crowd(rng: np.random.Generator, count: int) -> Scene:
    """``count`` convex obstacles of 3 to 7 vertices (pieces padded to the largest), 0.2 to 3 m across, in a
    24 x 24 m square about the origin, some overlapping."""
    obstacles = []
    for i in range(count):
        sides = int(rng.integers(3, 8))
        angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, sides))
        radius = rng.uniform(0.1, 1.5)
        ring = rng.uniform(-12.0, 12.0, 2) + radius * np.column_stack([np.cos(angles), np.sin(angles)])
        hull = shapely.convex_hull(shapely.MultiPoint(ring))
        if hull.geom_type == "Polygon" and hull.area > 1e-3:
            obstacles.append(Obstacle(f"o{i}", np.asarray(hull.exterior.coords, dtype=float)[:-1]))
    return Scene(tuple(obstacles))


@pytest.mark.parametrize("planes", [1, 3, 17])
def test_the_compiled_parameters_among_many_pieces_are_numpys(planes, shared_jit_cache):
    """In a crowd of pieces (most of them out of the lines' reach or farther than the nearest few, which the C
    does not measure) the compiled lines are NumPy's to the last bit: bodies over pieces, touching them and
    between them, anchored or not, keeping the warm start's lines or not; 17 planes measure every piece."""
    rng = np.random.default_rng(17 + planes)
    assert obstacles_module._kernel(True, str(shared_jit_cache[0])) is not None
    drawn = 0
    for _ in range(6):
        lines = ClearanceConstraints(VEHICLE, planes)
        lines.use(_crowd(rng, 60), float(rng.uniform(0.0, 0.4)))
        for trial in range(6):
            base = np.array([*rng.uniform(-10.0, 10.0, 2), rng.uniform(-np.pi, np.pi), rng.uniform(-0.6, 0.6)])
            walk = base + np.cumsum(rng.normal(0.0, [0.3, 0.3, 0.05, 0.05], (11, 4)), 0)
            plan = np.column_stack([walk, np.zeros((11, 2))])
            for anchored, keep_warm in ((True, False), (True, True), (False, False)):
                got = lines.parameters(Pose(), plan, anchored, keep_warm)
                assert np.array_equal(got, lines.parameters_numpy(Pose(), plan, anchored, keep_warm)), trial
                drawn += int(np.sum(got[2::3] != -1.0))
    assert drawn > 300 * planes  # lines drawn, not only unused slots


def test_pieces_at_the_same_distance_keep_their_order(shared_jit_cache):
    """A body that overlaps two pieces is at distance 0 from both: the lines come in the pieces' order, compiled or
    not, on any machine (a stable sort; NumPy's default one orders ties as its build and processor do)."""
    left = Obstacle("left", _box(4.0, 0.5, 0.0, 2.0, 1.0))
    right = Obstacle("right", _box(4.0, -0.5, 0.0, 2.0, 1.0))
    lines = ClearanceConstraints(VEHICLE, 2)
    lines.use(Scene((left, right)), 0.2)
    plan = np.column_stack([np.linspace(4.5, 3.5, 11), np.zeros((11, 5))])  # the trailer over both boxes
    got = lines.parameters(Pose(), plan)
    assert np.array_equal(got, lines.parameters_numpy(Pose(), plan))
    trailer = list(lines.bodies).index("trailer")
    slots = got.reshape(10, len(lines.bodies), 2, 3)[:, trailer]
    for slot, alone in enumerate((left, right)):  # each piece's line, drawn in a scene of that piece alone
        one = ClearanceConstraints(VEHICLE, 2)
        one.use(Scene((alone,)), 0.2)
        assert np.array_equal(slots[:, slot], one.parameters(Pose(), plan).reshape(10, -1, 2, 3)[:, trailer, 0])
    assert not np.array_equal(slots[:, 0], slots[:, 1])


def test_the_scene_is_cut_into_convex_pieces_that_cover_it():
    """Convex obstacles stay whole; a non-convex one and the ground outside the area become triangles; all
    counter-clockwise, covering exactly the obstacles and the ground near the area."""
    box = Obstacle("box", _box(0.0, 0.0, 0.3, 2.0, 1.0)[::-1])  # clockwise: either orientation
    ell = Obstacle("L", np.array([[3.0, 0.0], [6.0, 0.0], [6.0, 1.0], [4.0, 1.0], [4.0, 3.0], [3.0, 3.0]]))
    area = Area(np.array([[-10.0, -10.0], [10.0, -10.0], [10.0, 10.0], [0.0, 10.0], [0.0, 5.0], [-10.0, 5.0]]))
    pieces = convex_pieces(Scene((box, ell), area))
    shapes = [shapely.Polygon(p) for p in pieces]
    assert all(s.is_valid and s.exterior.is_ccw for s in shapes)
    assert all(shapely.equals(s, shapely.convex_hull(s)) for s in shapes)
    assert shapely.equals(shapes[0], shapely.Polygon(box.polygon))
    ground = shapely.box(-20.0, -20.0, 20.0, 20.0).difference(shapely.Polygon(area.boundary))
    union = shapely.union_all(shapes)
    want = shapely.union_all([shapely.Polygon(box.polygon), shapely.Polygon(ell.polygon)])
    assert union.intersection(shapely.box(-9.0, -9.0, 9.0, 4.0)).symmetric_difference(want).area < 1e-9
    assert union.contains(ground.intersection(shapely.box(-12.0, -12.0, 12.0, 12.0)).buffer(-1e-6))
    assert convex_pieces(Scene()) == []


VEHICLE = VehicleTrailer()
SCENE = Scene(
    (
        Obstacle("wall", np.array([[-6.0, 1.9], [8.0, 1.9], [8.0, 2.4], [-6.0, 2.4]])),
        Obstacle("car", _box(-1.0, -3.0, 0.0, 4.5, 1.8)),
    )
)


@pytest.mark.parametrize("anchored", [False, True])
def test_states_that_keep_to_the_lines_keep_the_clearance(anchored):
    """Sufficient, never optimistic: every configuration near the ones the lines were drawn at that meets
    all rows keeps the clearance from the scene (each piece within reach has a line); unused slots hold."""
    lines = ClearanceConstraints(VEHICLE, 3)
    lines.use(SCENE, 0.25)
    goal = Pose(0.5, -0.2, 0.05)
    rng = np.random.default_rng(3)
    kept = 0
    for _ in range(300):
        at = np.array([rng.uniform(0, 6), rng.uniform(-0.5, 0.5), rng.uniform(-0.2, 0.2), rng.uniform(-0.3, 0.3)])
        now = at + rng.normal(0.0, [0.5, 0.2, 0.05, 0.05]) if anchored else at
        params = lines.parameters(goal, np.vstack([now, at])).reshape(len(lines.bodies), 3, 3)
        unused = params[..., 2] == -1.0
        assert np.all(params[unused][:, :2] == 0.0)
        moved = at + rng.normal(0.0, [0.3, 0.3, 0.05, 0.05])
        corners = body_corners(VEHICLE, *moved)
        rows = [
            nx * px + ny * py - offset
            for name, planes in zip(lines.bodies, params, strict=True)
            for nx, ny, offset in planes
            for px, py in corners[name]
        ]
        assert lines.least_slack(np.vstack([now, moved]), params) == pytest.approx(min(rows))
        if min(rows) < 0.0:
            continue
        kept += 1
        x, y, yaw = from_goal_frame(goal, *moved[:3])
        assert clearance(VEHICLE, SCENE, x, y, yaw, moved[3]) >= 0.25 - 1e-9
    assert kept > 50  # the test saw many configurations that keep to the lines


def test_only_segments_within_reach_get_lines():
    lines = ClearanceConstraints(VEHICLE, 2)
    far = Scene((Obstacle("far", _box(0.0, 40.0, 0.0, 2.0, 2.0)),))
    lines.use(far, 0.2)
    params = lines.parameters(Pose(), np.zeros((4, 6)))
    assert params.shape == (3 * lines.n_params,)
    assert np.all(params.reshape(-1, 3) == [0.0, 0.0, -1.0])
    assert REACH_M < 40.0


def _plan_clearances(nmpc: FullNMPC, start: State, goal: Pose, scene: Scene) -> tuple[bool, float]:
    step = nmpc.act(Measurement(0.0, start, 0.0, 0.0), goal)
    least = math.inf
    for s in step.predicted_states[1:]:
        x, y, yaw = from_goal_frame(goal, *s[:3])
        least = min(least, clearance(VEHICLE, scene, x, y, yaw, s[3]))
    return step.ok, least


def test_the_obstacle_ocp_keeps_its_plan_clear_where_the_open_one_does_not():
    """A wall beside the approach: the plan of open space passes it closer than asked; the obstacle OCP's
    plan keeps the clearance at every predicted step, and still reverses towards the goal."""
    goal = Pose()
    start = State(7.0, 1.2, math.radians(-8.0), math.radians(-6.0))
    wall = Scene((Obstacle("wall", np.array([[0.5, 2.1], [5.0, 2.1], [5.0, 3.0], [0.5, 3.0]])),))
    need = 0.3
    nmpc = FullNMPC(VEHICLE, NMPCSettings(jit=False))
    ok, open_least = _plan_clearances(nmpc, start, goal, wall)
    assert ok and open_least < need
    nmpc.reset()
    nmpc.keep_clear(wall, need)
    ok, least = _plan_clearances(nmpc, start, goal, wall)
    assert ok and least >= need - 1e-6
    nmpc.keep_clear(Scene(), need)  # back in open space: the open OCP again
    nmpc.reset()
    assert _plan_clearances(nmpc, start, goal, wall)[1] == pytest.approx(open_least, abs=1e-6)


def test_eased_for_a_stage_that_begins_near_the_clearance_is_never_more_than_asked():
    goal = Pose()
    start = State(7.0, 1.2, math.radians(-8.0), math.radians(-6.0))
    wall = Scene((Obstacle("wall", np.array([[0.5, 2.1], [5.0, 2.1], [5.0, 3.0], [0.5, 3.0]])),))
    nmpc = FullNMPC(VEHICLE, NMPCSettings(jit=False))
    nmpc.keep_clear(wall, 0.3)
    nmpc.ease_clearance(0.5)
    assert nmpc.clearance_m == 0.3
    nmpc.ease_clearance(0.1)
    assert nmpc.clearance_m == 0.1
    nmpc.reset()
    ok, least = _plan_clearances(nmpc, start, goal, wall)
    assert ok and least >= 0.1 - 1e-6
    nmpc.keep_clear(wall, 0.3)  # asked again: the clearance asked
    assert nmpc.clearance_m == 0.3


class _FailingSolver:
    """A solver that never succeeds and answers with a wild iterate (as a failed interior-point run can)."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, **inputs: np.ndarray) -> dict[str, np.ndarray]:
        self.calls += 1
        x = np.asarray(inputs["x0"], dtype=float) + 1e6
        return {"x": x, "f": np.array(2e14), "lam_x": np.zeros_like(x), "lam_g": np.zeros(len(inputs["lbg"]))}

    def stats(self) -> dict[str, object]:
        return {"success": False, "return_status": "Maximum_Iterations_Exceeded"}


def test_a_cold_start_whose_rounds_all_fail_starts_from_the_plan_without_lines(monkeypatch):
    """Among obstacles a cold start solves the OCP without lines first, then, where that plan passes too
    close, the obstacle OCP in rounds. When every round fails, the primary solver starts from the plan
    without lines, never from a failed round's iterate (given one, the solvers spend minutes on it)."""
    goal = Pose()
    start = State(7.0, 1.2, math.radians(-8.0), math.radians(-6.0))
    wall = Scene((Obstacle("wall", np.array([[0.5, 2.1], [5.0, 2.1], [5.0, 3.0], [0.5, 3.0]])),))
    nmpc = FullNMPC(VEHICLE, NMPCSettings(jit=False))
    open_plan = nmpc.act(Measurement(0.0, start, 0.0, 0.0), goal)  # the plan without lines: too close here
    nmpc.reset()
    nmpc.keep_clear(wall, 0.3)
    failing = _FailingSolver()
    monkeypatch.setattr(nmpc, "_general_solver", lambda program=None: failing)

    class StartsFromTheOpenPlan(list):
        """Checks each problem the primary solver is given as it is posed (a wild start would hang it)."""

        def append(self, problem: NLPProblem) -> None:
            states, inputs = nmpc.transcription.unpack(problem.w0, problem.p)
            np.testing.assert_allclose(states, open_plan.predicted_states, atol=1e-6)
            np.testing.assert_allclose(inputs, open_plan.predicted_inputs, atol=1e-6)
            super().append(problem)

    nmpc.recorder = StartsFromTheOpenPlan()
    step = nmpc.act(Measurement(0.0, start, 0.0, 0.0), goal)
    assert failing.calls >= COLD_ROUNDS  # every round tried (again if the cascade starts cold once more)
    assert len(nmpc.recorder) >= 1
    assert step.ok or step.stop  # an answer or a safe stop


def test_lines_within_reach_are_those_of_all_pieces_and_none_far_off():
    """``lines(..., reach)`` measures only the pairs of body and piece whose boxes come within reach: where
    it measures, the same distances and lines as measuring every pair; elsewhere no distance; and a body
    far from every piece gets none at all (no pair to measure)."""
    lines = ClearanceConstraints(VEHICLE, 2)
    lines.use(SCENE, 0.25)
    goal = Pose(0.5, -0.2, 0.05)
    rng = np.random.default_rng(5)
    for _ in range(40):
        at = np.array([rng.uniform(-2, 8), rng.uniform(-1.5, 1.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3)])
        corners = body_corners(VEHICLE, *at)
        quads = []
        for name in lines.bodies:
            points = [np.array(p, dtype=float) for p in corners[name]]
            quads.append(np.stack(points if len(points) == 4 else [*points, *points[::-1]]))
        bodies = np.stack(quads)
        every = lines.lines(bodies, goal)
        near = lines.lines(bodies, goal, reach=REACH_M)
        measured = np.isfinite(near[0])
        assert np.all(every[0][~measured] > REACH_M)  # only far pairs go unmeasured
        np.testing.assert_array_equal(near[0][measured], every[0][measured])
        np.testing.assert_array_equal(near[1][measured], every[1][measured])
        np.testing.assert_array_equal(near[2][measured], every[2][measured])
    far = bodies + 100.0
    distance, _, _ = lines.lines(far, goal, reach=REACH_M)
    assert np.all(np.isinf(distance))


def test_a_warm_start_that_keeps_the_clearance_keeps_to_its_own_lines():
    """``keep_warm``: wherever the car is now, a warm start whose bodies keep the clearance at a step meets
    every line drawn for that step (anchored lines alone can cut it where it rounds a piece)."""
    lines = ClearanceConstraints(VEHICLE, 3)
    lines.use(SCENE, 0.25)
    goal = Pose(0.5, -0.2, 0.05)
    rng = np.random.default_rng(8)
    checked = cut_without = 0
    for _ in range(300):
        now = np.array([rng.uniform(-1, 7), rng.uniform(-0.8, 0.8), rng.uniform(-0.6, 0.6), rng.uniform(-0.4, 0.4)])
        at = now + rng.normal(0.0, [1.5, 0.6, 0.3, 0.2])
        x, y, yaw = from_goal_frame(goal, *at[:3])
        if clearance(VEHICLE, SCENE, x, y, yaw, at[3]) < 0.25:
            continue
        checked += 1
        states = np.vstack([now, at])
        kept = lines.parameters(goal, states, keep_warm=True)
        assert lines.least_slack(states, kept) >= -1e-9
        cut_without += lines.least_slack(states, lines.parameters(goal, states)) < -1e-9
    assert checked > 100 and cut_without > 0  # the anchored lines alone do cut some of them
