"""USD files: round trip (float32), stage metadata, the instancer's orientations."""

import numpy as np
import pytest

from crowdmotion import Trajectories
from crowdmotion.io.usd import from_usd_frame, to_usd_frame
from crowdmotion.scene import Box, Circle, Scene
from tests.io.test_roundtrip import sample

pxr = pytest.importorskip("pxr")


@pytest.mark.parametrize("suffix", ["usd", "usda", "usdc"])
@pytest.mark.parametrize("dim", [2, 3])
def test_roundtrip_float32_and_timing(tmp_path, suffix, dim):
    tr = sample(dim)
    if dim == 2:
        tr.metadata["scene"] = Scene(((-5, -5), (5, 5)), [Circle((3, 3), 0.5), Box((-4, -4), (-3, -2))]).to_dict()
    back = Trajectories.load(tr.save(tmp_path / f"t.{suffix}", dcc_rate=False))  # the run's own frames
    np.testing.assert_allclose(back.positions, tr.positions.astype(np.float32), rtol=1e-6, atol=1e-6)
    assert back.dt == pytest.approx(0.25)
    np.testing.assert_array_equal(back.active_mask, tr.active_mask)
    assert back.group.tolist() == tr.group.tolist()
    np.testing.assert_allclose(back.radius, tr.radius, rtol=1e-6)


def test_stage_is_y_up_in_metres_at_the_run_frame_rate_with_headings(tmp_path):
    from pxr import Usd, UsdGeom

    pos = np.zeros((3, 1, 2))
    pos[:, 0, 1] = [0.0, 1.0, 2.0]  # walking along +y (north)
    path = Trajectories(pos, 0.5).save(tmp_path / "north.usda")
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == "Y" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    # a 2 fps run on a 24 fps stage: frame f at time code f x 0.5 s x 24
    assert stage.GetTimeCodesPerSecond() == 24.0 and stage.GetEndTimeCode() == 24
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    q = inst.GetOrientationsAttr().Get(12)[0]
    # the prototype's forward (-Y, a Blender character's) turned to north, which is USD -Z; its up (+Z) to +Y
    from pxr import Gf
    turn = Gf.Rotation(Gf.Quatd(q.GetReal(), Gf.Vec3d(q.GetImaginary())))
    v = turn.TransformDir(Gf.Vec3d(0, -1, 0))
    assert (v[0], v[1], v[2]) == pytest.approx((0.0, 0.0, -1.0), abs=1e-3)
    assert tuple(turn.TransformDir(Gf.Vec3d(0, 0, 1))) == pytest.approx((0.0, 1.0, 0.0), abs=1e-3)
    np.testing.assert_allclose(np.array(inst.GetPositionsAttr().Get(24))[0], [0.0, 0.0, -2.0])
    np.testing.assert_allclose(np.array(inst.GetPositionsAttr().Get(6))[0], [0.0, 0.0, -0.5], atol=1e-6)


def test_obstacles_sit_where_the_scene_has_them_and_move_on_time(tmp_path):
    # issue 17: box translates were scaled, moving obstacles' samples were in seconds
    from pxr import Usd, UsdGeom

    import crowdmotion as cm

    scene = cm.Scene(bounds=([0, 0], [60, 20]), obstacles=[
        cm.Box([10, 2], [14, 5]), cm.Circle([30, 10], 1.0, path=([0, 3, 4], [[30, 10], [36, 10], [36, 14]]))])
    pos = np.zeros((41, 1, 2))
    pos[:, 0, 0] = np.linspace(1, 5, 41)
    tr = Trajectories(pos, 0.1, metadata={"scene": scene.to_dict()})
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "o.usda")))
    cache = UsdGeom.BBoxCache(Usd.TimeCode.Default(), ["default"])
    box = cache.ComputeWorldBound(stage.GetPrimAtPath("/World/Obstacles/obstacle_0")).ComputeAlignedRange()
    lo, hi = np.array(box.GetMin()), np.array(box.GetMax())
    np.testing.assert_allclose([lo[0], -hi[2], hi[0], -lo[2]], [10, 2, 14, 5], atol=1e-6)  # USD (x, z) = (x, -y)
    moving = UsdGeom.Xformable(stage.GetPrimAtPath("/World/Obstacles/obstacle_1"))
    for t, (x, y) in ((0, (30, 10)), (3, (36, 10)), (3.5, (36, 12))):
        m = moving.ComputeLocalToWorldTransform(Usd.TimeCode(t * 24.0))
        np.testing.assert_allclose([m[3][0], -m[3][2]], [x, y], atol=1e-6)


def test_an_obstacle_that_stands_for_a_while_is_visible_only_then(tmp_path):
    from pxr import Usd, UsdGeom

    from tests.io.readers import door_session

    traj, door = door_session()  # a door dropped in at 1 s and taken away at 2 s
    stage = Usd.Stage.Open(str(traj.save(tmp_path / "live.usda", dcc_rate=False)))
    prim = UsdGeom.Imageable(stage.GetPrimAtPath(f"/World/Obstacles/obstacle_{door}"))
    seen = {t: prim.ComputeVisibility(Usd.TimeCode(t * stage.GetTimeCodesPerSecond())) for t in (0.0, 0.5, 1.5, 2.5)}
    assert seen == {0.0: "invisible", 0.5: "invisible", 1.5: "inherited", 2.5: "invisible"}
    codes = stage.GetPrimAtPath("/World/Crowd").GetAttribute("positions").GetTimeSamples()
    assert len(codes) == 31 and all(c == round(c, 9) for c in codes), "2.4, not 2.4000000000000004"
    fps24 = Trajectories(np.zeros((49, 1, 2)), 1 / 24).save(tmp_path / "24.usda")
    stage24 = Usd.Stage.Open(str(fps24))
    codes = stage24.GetPrimAtPath("/World/Crowd").GetAttribute("positions").GetTimeSamples()
    assert codes == list(range(49)), "whole time codes at 24 fps, not 6.999999999999999"


def test_axis_mapping_is_its_own_inverse():
    p = np.random.default_rng(0).normal(size=(5, 3))
    np.testing.assert_allclose(from_usd_frame(to_usd_frame(p), 3), p)
    np.testing.assert_allclose(to_usd_frame(p[:, :2])[:, 1], 0.0)  # 2D lies on the ground


def test_failed_usd_write_leaves_nothing(tmp_path, monkeypatch):
    from crowdmotion.io import usd

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(usd, "_obstacles", boom)
    tr = sample(2)
    tr.metadata["scene"] = Scene(((-5, -5), (5, 5))).to_dict()
    with pytest.raises(RuntimeError):
        tr.save(tmp_path / "t.usdc")
    assert list(tmp_path.iterdir()) == []


def test_prototypes_are_named_after_groups_and_points_carry_velocity_and_colour(tmp_path):
    from pxr import Usd, UsdGeom

    pos = np.zeros((4, 2, 2))
    pos[:, 0, 0] = [0.0, 1.0, 2.0, 3.0]  # walking east at 2 m/s (dt 0.5)
    pos[:, 1, 1] = 5.0
    tr = Trajectories(pos, 0.5, group=np.array(["red", "walkers"], dtype=object))
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "v.usda")))
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    names = [str(p.name) for p in inst.GetPrototypesRel().GetTargets()]
    assert names == ["red_0", "walkers_1"]
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Agents"))
    v = np.array(points.GetVelocitiesAttr().Get(12.0))  # frame 1 at 24 time codes per second
    np.testing.assert_allclose(v[0], [2.0, 0.0, 0.0], atol=1e-6)  # east is USD +x
    colour = np.array(points.GetDisplayColorPrimvar().Get())
    np.testing.assert_allclose(colour[0], [1.0, 0.0, 0.0])
    primvars = UsdGeom.PrimvarsAPI(points)
    assert list(primvars.GetPrimvar("group").Get()) == [0, 1]  # red_0, walkers_1
    np.testing.assert_allclose(primvars.GetPrimvar("speed").Get(12.0), [2.0, 0.0], atol=1e-6)


def test_3d_flyers_face_their_way_with_pitch_and_are_centred_on_the_point(tmp_path):
    # issue 17: 3D runs got a yaw-only orientation and a capsule standing on the point
    from pxr import Gf, Usd, UsdGeom

    pos = np.zeros((3, 1, 3))
    pos[:, 0, 1] = [0.0, 1.0, 2.0]  # north ...
    pos[:, 0, 2] = [5.0, 6.0, 7.0]  # ... climbing at 45°
    stage = Usd.Stage.Open(str(Trajectories(pos, 0.5, radius=[0.3]).save(tmp_path / "drone.usda")))
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    q = inst.GetOrientationsAttr().Get(12)[0]
    forward = Gf.Rotation(Gf.Quatd(q.GetReal(), Gf.Vec3d(q.GetImaginary()))).TransformDir(Gf.Vec3d(0, -1, 0))
    s = np.sqrt(0.5)
    assert tuple(forward) == pytest.approx((0.0, s, -s), abs=2e-3)  # world (0, s, s): north is USD -Z
    proto = stage.GetPrimAtPath(inst.GetPrototypesRel().GetTargets()[0])
    cap = UsdGeom.Capsule(proto)
    assert cap.GetAxisAttr().Get() == "Y" and not UsdGeom.Xformable(proto).GetOrderedXformOps()  # along forward
    lo, hi = (np.array(v) for v in cap.GetExtentAttr().Get())
    np.testing.assert_allclose(lo, -hi)  # centred on the point


def test_orientations_turn_then_raise_like_gf_rotations():
    from pxr import Gf

    from crowdmotion.io.usd import orientations

    rng = np.random.default_rng(1)
    for heading, pitch in zip(rng.uniform(-np.pi, np.pi, 5), rng.uniform(-1.2, 1.2, 5)):
        w, i, j, k = orientations(np.array(heading), np.array(pitch))
        want = (Gf.Rotation(Gf.Vec3d(0, 0, 1), np.degrees(pitch)) * Gf.Rotation(Gf.Vec3d(0, 1, 0), np.degrees(heading)))
        got = Gf.Rotation(Gf.Quatd(float(w), Gf.Vec3d(float(i), float(j), float(k))))
        for axis in (Gf.Vec3d(1, 0, 0), Gf.Vec3d(0, 1, 0)):
            assert tuple(got.TransformDir(axis)) == pytest.approx(tuple(want.TransformDir(axis)), abs=1e-9)


def test_every_boundable_prim_has_its_extent(tmp_path):
    from pxr import Usd, UsdGeom

    tr = sample(2)
    tr.metadata["scene"] = Scene(((-5, -5), (5, 5)), [Circle((3, 3), 0.5), Box((-4, -4), (-3, -2))]).to_dict()
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "e.usda")))
    boundables = [p for p in stage.Traverse() if p.IsA(UsdGeom.Boundable)]
    assert len(boundables) >= 5  # agents, crowd, a prototype, two obstacles
    for prim in boundables:
        assert UsdGeom.Boundable(prim).GetExtentAttr().HasAuthoredValue(), prim.GetPath()
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Agents"))
    code = points.GetPointsAttr().GetTimeSamples()[3]
    lo, hi = (np.array(v) for v in points.GetExtentAttr().Get(code))
    p = np.array(points.GetPointsAttr().Get(code))
    w = np.array(points.GetWidthsAttr().Get(code))[:, None] / 2
    np.testing.assert_allclose(lo, (p - w).min(axis=0), atol=1e-6)
    np.testing.assert_allclose(hi, (p + w).max(axis=0), atol=1e-6)


@pytest.mark.parametrize("up, forward", [("Z", "-Y"), ("Y", "Z"), ("Y", "X"), ("-X", "Z")])
def test_prototypes_stand_on_the_stage_up_and_face_their_agents_way_in_any_axes(tmp_path, up, forward):
    from pxr import Usd, UsdGeom

    from crowdmotion.io.usd import AXES, rotate

    rng = np.random.default_rng(2)
    pos = np.cumsum(rng.normal(0, 0.3, (12, 5, 2)), axis=0)
    tr = Trajectories(pos, 0.5)
    path = tr.save(tmp_path / "a.usda", prototype_up=up, prototype_forward=forward, dcc_rate=False)
    stage = Usd.Stage.Open(str(path))
    data = stage.GetMetadata("customLayerData")
    assert (data["crowdmotion_prototype_up"], data["crowdmotion_prototype_forward"]) == (up, forward)
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    code = inst.GetOrientationsAttr().GetTimeSamples()[7]
    frame = int(round(code / stage.GetTimeCodesPerSecond() / 0.5))
    q = np.array([[*o.GetImaginary(), o.GetReal()] for o in inst.GetOrientationsAttr().Get(code)])
    np.testing.assert_allclose(rotate(q, AXES[up]), np.tile([0.0, 1.0, 0.0], (5, 1)), atol=2e-3)
    yaw = tr.facing[frame]
    want = np.stack([np.cos(yaw), np.zeros(5), -np.sin(yaw)], axis=1)  # world (cos, sin, 0) in USD (x, z, -y)
    np.testing.assert_allclose(rotate(q, AXES[forward]), want, atol=2e-3)
    # the walker prototype stands on the point along its up axis, 1.7 m tall
    proto = UsdGeom.Mesh(stage.GetPrimAtPath(inst.GetPrototypesRel().GetTargets()[0]))
    assert not proto.GetOrderedXformOps()
    along = np.array(proto.GetPointsAttr().Get()) @ np.array(AXES[up])
    assert along.min() == pytest.approx(0.0, abs=1e-6) and along.max() == pytest.approx(1.7, abs=1e-6)
    back = Trajectories.load(path)
    np.testing.assert_allclose(np.cos(back.facing - tr.facing), 1.0, atol=1e-5)  # facing read through the axes


@pytest.mark.parametrize("options, message", [
    ({"prototype_up": "W"}, "prototype_up must be one of X, Y, Z, -X, -Y, -Z .*got 'W'"),
    ({"prototype_forward": 3}, "prototype_forward must be one of .*got 3"),
    ({"prototype_up": "y", "prototype_forward": "-Y"}, "must be perpendicular axes, got up 'Y' and forward '-Y'"),
])
def test_bad_prototype_axes_are_refused_naming_them(tmp_path, options, message):
    with pytest.raises(ValueError, match=message):
        sample(2).save(tmp_path / "bad.usda", **options)
    assert list(tmp_path.iterdir()) == []


def test_the_points_are_a_guide_with_orient_and_both_prims_carry_the_locomotion_primvars(tmp_path):
    from pxr import Usd, UsdGeom

    from crowdmotion.locomotion import MOVE, WALK, locomotion

    t = np.arange(49) / 24
    pos = np.zeros((49, 2, 2))
    pos[:, 0, 0] = 1.2 * t  # a walker
    pos[:, 1, 1] = 5.0 * t  # a car
    tr = Trajectories(pos, 1 / 24, group=np.array(["people", "traffic"], dtype=object),
                      metadata={"bodies": {"traffic": "car"}})
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "l.usda")))
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Agents"))
    assert points.GetPurposeAttr().Get() == UsdGeom.Tokens.guide
    inst = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd"))
    assert UsdGeom.Imageable(inst).ComputePurpose() == UsdGeom.Tokens.default_
    code = 24.0
    orient = UsdGeom.PrimvarsAPI(points).GetPrimvar("orient").Get(code)
    np.testing.assert_allclose([tuple(o.GetImaginary()) + (o.GetReal(),) for o in orient],
                               [tuple(o.GetImaginary()) + (o.GetReal(),) for o in inst.GetOrientationsAttr().Get(code)],
                               atol=1e-3)
    loco = locomotion(tr)
    for prim in (points, inst):
        api = UsdGeom.PrimvarsAPI(prim)
        np.testing.assert_allclose(api.GetPrimvar("distance").Get(code), loco.distance[24], rtol=1e-6)
        assert list(api.GetPrimvar("gait_state").Get(code)) == [WALK, MOVE]
        phase = np.array(api.GetPrimvar("gait_phase").Get(code))
        assert phase[0] == pytest.approx(loco.gait_phase[24, 0], abs=1e-6) and phase[1] == -1.0  # a car has none
        assert list(api.GetPrimvar("contact_left").Get(code))[1] == 0
        assert api.GetPrimvar("turn_rate").Get(code) is not None and api.GetPrimvar("speed").Get(code) is not None


def test_the_points_carry_what_houdinis_crowd_tools_read(tmp_path):
    """docs/exporting.md's Houdini paragraph: /World/Agents' points carry widths, ids,
    velocities (Houdini's v), orient and the locomotion primvars, one value per point
    (vertex interpolation: point attributes in Houdini); exported with Houdini's axes
    (Y up, facing +Z) orient turns +Z to the agent's facing and keeps +Y up."""
    from pxr import Gf, Sdf, Usd, UsdGeom

    from crowdmotion.locomotion import IDLE, WALK

    t = np.arange(49) / 24
    pos = np.zeros((49, 3, 2))
    pos[:, 0, 0] = 1.3 * t  # east
    pos[:, 1, 1] = 1.3 * t  # north
    pos[:, 2] = [4.0, 4.0]  # stands
    tr = Trajectories(pos, 1 / 24, radius=[0.25, 0.3, 0.2])
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "h.usda", prototype_up="Y", prototype_forward="Z")))
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Agents"))
    code = 24.0
    np.testing.assert_allclose(points.GetWidthsAttr().Get(code), [0.5, 0.6, 0.4], rtol=1e-6)
    assert list(points.GetIdsAttr().Get(code)) == [0, 1, 2]
    v = np.array(points.GetVelocitiesAttr().Get(code))
    np.testing.assert_allclose(v, [[1.3, 0, 0], [0, 0, -1.3], [0, 0, 0]], atol=1e-5)  # world north is USD -Z
    api = UsdGeom.PrimvarsAPI(points)
    kinds = {"orient": Sdf.ValueTypeNames.QuatfArray, "gait_phase": None, "gait_state": None, "distance": None,
             "turn_rate": None, "contact_left": None, "contact_right": None, "speed": None}
    for name, kind in kinds.items():
        var = api.GetPrimvar(name)
        assert var and var.GetInterpolation() == UsdGeom.Tokens.vertex, name  # a point attribute in Houdini
        assert len(var.Get(code)) == 3, name
        if kind is not None:
            assert var.GetTypeName() == kind, name
    loco = tr.locomotion()
    np.testing.assert_allclose(api.GetPrimvar("gait_phase").Get(code), loco.gait_phase[24], atol=1e-6)
    assert list(api.GetPrimvar("gait_state").Get(code)) == [WALK, WALK, IDLE]
    for i, want in ((0, (1, 0, 0)), (1, (0, 0, -1))):  # +Z (the prototype's front) to the facing
        q = api.GetPrimvar("orient").Get(code)[i]
        rot = Gf.Rotation(Gf.Quatd(q.GetReal(), Gf.Vec3d(q.GetImaginary())))
        np.testing.assert_allclose(rot.TransformDir(Gf.Vec3d(0, 0, 1)), want, atol=2e-3)
        np.testing.assert_allclose(rot.TransformDir(Gf.Vec3d(0, 1, 0)), (0, 1, 0), atol=2e-3)  # upright


def test_a_run_of_few_frames_a_second_is_written_at_24_for_a_character(tmp_path):
    # saved from Python as `crowdmotion export` writes it: a 4 fps run at 24 fps along its
    # B-spline (a character bound to the steps would jolt at every one), NTSC rates kept
    from pxr import Usd

    tr = sample(2)  # 4 frames a second
    back = Trajectories.load(tr.save(tmp_path / "t.usdc"))
    assert back.fps == pytest.approx(24.0) and back.n_frames == (tr.n_frames - 1) * 6 + 1
    np.testing.assert_allclose(back.positions[::6][back.active_mask[::6]][:1], tr.positions[tr.active_mask][:1], atol=0.05)
    own = Trajectories(np.zeros((49, 1, 2)), 1 / 23.976).save(tmp_path / "ntsc.usda")
    stage = Usd.Stage.Open(str(own))
    assert stage.GetTimeCodesPerSecond() == pytest.approx(23.976) and stage.GetEndTimeCode() == pytest.approx(48)


def test_a_file_at_a_whole_rate_of_its_own_runs_at_that_rate_with_a_sample_on_every_time_code(tmp_path):
    # export --fps 12 wrote samples on the even codes of a 24 time-code stage: a DCC
    # reading every code interpolated the gait phase across its wrap, half a stride back
    from pxr import Usd

    from crowdmotion.smoothing import at_rate
    from tests.io.readers import door_session

    traj, _ = door_session()

    at12 = at_rate(traj, 12.0)
    stage = Usd.Stage.Open(str(at12.save(tmp_path / "t12.usda", dcc_rate=False)))
    assert stage.GetTimeCodesPerSecond() == 12.0 and stage.GetFramesPerSecond() == 12.0
    codes = stage.GetPrimAtPath("/World/Crowd").GetAttribute("positions").GetTimeSamples()
    assert codes == list(range(at12.n_frames))
    odd = Trajectories(np.zeros((20, 1, 2)), 1 / 7.5).save(tmp_path / "odd.usda", dcc_rate=False)
    assert Usd.Stage.Open(str(odd)).GetTimeCodesPerSecond() == 24.0  # no whole rate: the DCCs' default


@pytest.mark.parametrize("turn", [1, -1])
def test_a_polygon_obstacle_stands_as_a_closed_prism_facing_out_whichever_way_it_was_wound(turn):
    # counter-clockwise polygons (mdp_robots_2d's) came out as one flat face at height 0
    # facing into the ground
    from crowdmotion.io.usd import OBSTACLE_HEIGHT, _face_normal, polygon_prism

    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])[::turn]
    points, counts, indices = polygon_prism(square, OBSTACLE_HEIGHT)
    faces, at = [], 0
    for c in counts:
        faces.append(indices[at:at + c])
        at += c
    normals = np.array([_face_normal(points, f) for f in faces])
    assert normals[0][1] > 0 and normals[1][1] < 0, "top up, bottom down"
    centre = points.mean(axis=0)
    for f, nrm in zip(faces, normals):
        assert np.dot(nrm, points[f].mean(axis=0) - centre) > 0, "every face outwards"
    # the divergence theorem: a closed, outward-wound mesh encloses a positive volume (2 x 1 x 2 m)
    volume = sum(np.dot(points[f[0]], np.cross(points[f[i]], points[f[i + 1]])) for f in faces
                 for i in range(1, len(f) - 1)) / 6
    assert volume == pytest.approx(2.0 * 1.0 * OBSTACLE_HEIGHT)


def test_the_velocity_motion_blur_reads_is_the_frame_s_own_and_never_differences_an_absent_frame(tmp_path):
    from pxr import Usd, UsdGeom

    t = np.arange(10) / 24
    pos = np.stack([np.c_[1.2 * t ** 2 * 12, np.zeros(10)], np.c_[1.0 * t, np.ones(10)]], axis=1)
    active = np.ones((10, 2), bool)
    active[7:, 1] = False  # the second leaves after frame 6
    tr = Trajectories(pos, 1 / 24, active=active)
    stage = Usd.Stage.Open(str(tr.save(tmp_path / "v.usda", dcc_rate=False)))
    vel = UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Crowd")).GetVelocitiesAttr()
    v4 = np.array(vel.Get(4.0))
    assert v4[0, 0] == pytest.approx((pos[5, 0, 0] - pos[3, 0, 0]) * 12, rel=1e-5)  # central: the frame's own
    assert np.array(vel.Get(6.0))[1, 0] == pytest.approx(1.0, rel=1e-5)  # its last frame: walking, not 0


def test_an_ntsc_rate_is_written_as_the_user_gave_it():
    from crowdmotion.io.usd import stage_rate

    assert stage_rate(Trajectories(np.zeros((3, 1, 2)), 1 / 29.97)) == 29.97  # not 29.969999999999995
    assert stage_rate(Trajectories(np.zeros((3, 1, 2)), 1 / 24)) == 24.0
