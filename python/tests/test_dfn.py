"""DFNs from Python: every DFN and DFI of the registry reachable through the generated classes,
parameters checked by the C++ reader (same messages), results on synthetic truth, bad input as
exceptions, and process() running without the GIL."""
import threading
import time

import numpy as np
import pytest

import cdff
from cdff import _core


def test_every_registered_dfi_is_reachable_with_typed_ports():
    registered = _core.implementations()
    assert registered, "the registry is empty: the DFIs were not linked into the module"
    for dfn_name, dfi in registered:
        cls = getattr(cdff.dfn, dfn_name)
        assert dfi in cls.implementations
        node = cdff.dfn.create(f"{dfn_name}/{dfi}")
        assert node.implementation == dfi
        for direction, port, type_name in _core.port_types(dfn_name):
            assert cdff.python_type_of(type_name) is not None, (dfn_name, port, type_name)
            ports = node.inputs if direction == "input" else node.outputs
            assert getattr(ports, port) is None  # nothing set or produced yet
    # and no generated class without a registered DFI
    assert {n for n, _ in registered} == set(cdff.dfn.__all__) - {"create"}


def test_parameters_are_checked_as_yaml_files_are():
    canny = cdff.dfn.EdgeDetection("Canny", low_threshold=20, l2_gradient=True)
    assert canny.parameters["low_threshold"] == 20.0 and canny.parameters["l2_gradient"] is True
    with pytest.raises(cdff.InvalidParameterError,
                       match=r"low_threshold = -3: out of range; expected a number in \[0, 10000\]"):
        canny.configure(low_threshold=-3)
    assert canny.parameters["low_threshold"] == 20.0  # unchanged after the error
    with pytest.raises(cdff.InvalidParameterError, match="low_treshold"):
        canny.configure(low_treshold=3)
    with pytest.raises(cdff.InvalidParameterError, match="aperture_size"):
        canny.configure(aperture_size="three")
    with pytest.raises(TypeError, match="cannot be a parameter value"):
        canny.configure(low_threshold={"a": 1})


def test_angles_are_in_degrees_as_in_yaml():
    ekf = cdff.dfn.EstimationFilter(attitude_sigma=2.0)
    assert ekf.parameters["attitude_sigma"] == pytest.approx(2.0)


def test_names_that_do_not_exist():
    with pytest.raises(cdff.NotFoundError, match="Cany"):
        cdff.dfn.EdgeDetection("Cany")
    with pytest.raises(LookupError, match="no DFN named 'EdgeDetector'"):
        cdff.dfn.create("EdgeDetector/Canny")
    canny = cdff.dfn.EdgeDetection()
    with pytest.raises(AttributeError):
        canny.imag = None  # a misspelt port is not silently a new attribute


def test_edges_of_a_square_on_synthetic_truth():
    a = np.zeros((120, 160), np.uint8)
    a[40:80, 50:110] = 200
    canny = cdff.dfn.EdgeDetection("Canny")
    canny.image = cdff.Image(a, stamp=42)
    canny.process()
    edges = canny.edges
    assert edges.stamp == 42
    ys, xs = np.nonzero(edges.array)
    # every edge pixel within one pixel of the square's border, and the border found all around
    on_border = (np.minimum(np.abs(ys - 39.5), np.abs(ys - 79.5)) <= 1.5) | \
                (np.minimum(np.abs(xs - 49.5), np.abs(xs - 109.5)) <= 1.5)
    assert on_border.all()
    assert len(xs) >= 2 * (40 + 60) * 0.9


def box_surface(rng, n):
    """n points on the surface of a 2 x 1 x 0.5 m box (a model with no symmetry ICP could slide
    on), and their outward normals."""
    half = np.array([1.0, 0.5, 0.25])
    p = rng.uniform(-1, 1, size=(n, 3)) * half
    face = rng.integers(0, 3, n)
    sign = rng.choice([-1.0, 1.0], n)
    p[np.arange(n), face] = sign * half[face]
    normals = np.zeros((n, 3))
    normals[np.arange(n), face] = sign
    return p, normals


def test_icp_recovers_a_known_transform():
    rng = np.random.default_rng(7)
    model, normals = box_surface(rng, 4000)
    angle = np.radians(4.0)
    truth = cdff.Transform([0.05, -0.03, 0.02], [0, 0, np.sin(angle / 2), np.cos(angle / 2)],
                           "scene", "model")
    scene = truth.apply(box_surface(rng, 4000)[0])
    icp = cdff.dfn.Registration3D("FastIcp")
    icp.model = cdff.PointCloud(model, normals=normals, frame_id="model", copy=True)
    icp.source = cdff.PointCloud(scene, frame_id="scene", copy=True)
    icp.initial_guess = cdff.Transform([0, 0, 0], [0, 0, 0, 1], "scene", "model")
    icp.process()
    found = icp.transform
    # one point spacing of the model's surface (about 2 cm) bounds what ICP can resolve
    assert np.linalg.norm(found.translation - truth.translation) < 0.01
    assert np.degrees(cdff.angular_distance(found.quaternion_xyzw, truth.quaternion_xyzw)) < 0.3
    assert icp.converged


def test_bad_input_is_an_exception_with_the_cxx_message():
    canny = cdff.dfn.EdgeDetection()
    with pytest.raises(cdff.InvalidInputError, match="image"):
        canny.process()  # required input missing
    with pytest.raises(TypeError, match=r"input 'image' takes a cdff.Image \(Image\); got a Python ndarray"):
        canny.image = np.zeros((4, 4), np.uint8)
    canny.image = cdff.Image(np.zeros((4, 4), np.float32))
    with pytest.raises(cdff.InvalidInputError, match="32FC1"):
        canny.process()
    assert canny.diagnostics.error_count == 2
    icp = cdff.dfn.Registration3D()
    nan = np.zeros((100, 4), np.float32)
    nan[3, 0] = np.nan
    icp.model = cdff.PointCloud(nan)
    icp.source = cdff.PointCloud(np.zeros((100, 4), np.float32))
    with pytest.raises(cdff.InvalidInputError, match="nan"):
        icp.process()


def test_ports_shared_by_input_and_output():
    ft = cdff.dfn.FrameTransformation()
    assert "pose" in ft.input_types and "pose" in ft.output_types
    assert not hasattr(type(ft), "pose")  # no shortcut when the name is ambiguous
    ft.inputs.pose = cdff.PoseWithCovariance(cdff.Transform([1, 0, 0], [0, 0, 0, 1], "b", "c"))
    assert ft.inputs.pose.pose.child_frame == "c" and ft.outputs.pose is None


def test_process_releases_the_gil():
    big = np.random.default_rng(3).integers(0, 255, (2500, 2500)).astype(np.uint8)
    image = cdff.Image(big)
    nodes = [cdff.dfn.EdgeDetection("Canny", l2_gradient=True) for _ in range(2)]
    for n in nodes:
        n.image = image
    intervals = [None, None]

    def run(i):
        start = time.perf_counter()
        for _ in range(3):
            nodes[i].process()
        intervals[i] = (start, time.perf_counter())

    # Python work in this thread progresses while another thread is inside process()
    worker = threading.Thread(target=run, args=(0,))
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1
    worker.join()
    assert ticks > 1000, f"only {ticks} Python loop iterations ran during process()"

    # two DFNs in two Python threads run at the same time: their calls overlap for most of
    # their length (with the GIL held they could overlap by a switch interval at most)
    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    overlap = min(e for _, e in intervals) - max(s for s, _ in intervals)
    shortest = min(e - s for s, e in intervals)
    assert overlap > 0.5 * shortest, (intervals, overlap)
