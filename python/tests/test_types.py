"""Data types to and from NumPy: shared memory where the layout allows, copies that say so, and
exceptions with the C++ message for bad arrays."""
import warnings

import numpy as np
import pytest

import cdff


def no_copy_warning():
    """A context that turns a cdff.CopyWarning into a test failure."""
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("error", cdff.CopyWarning)
    return ctx


class TestImage:
    @pytest.mark.parametrize("dtype, shape, fmt", [
        (np.uint8, (48, 64), cdff.PixelFormat.GRAY8),
        (np.uint8, (48, 64, 3), cdff.PixelFormat.BGR8),
        (np.uint16, (48, 64), cdff.PixelFormat.GRAY16),
        (np.float32, (48, 64), cdff.PixelFormat.FLOAT32),
    ])
    def test_array_is_shared_both_ways(self, dtype, shape, fmt):
        a = (np.arange(np.prod(shape)) % 250).astype(dtype).reshape(shape)
        with warnings.catch_warnings():
            warnings.simplefilter("error", cdff.CopyWarning)
            image = cdff.Image(a, stamp=12, frame_id="cam")
        assert image.format == fmt and (image.width, image.height) == (64, 48)
        view = image.array
        assert np.shares_memory(view, a)
        assert not view.flags.writeable
        np.testing.assert_array_equal(view, a)

    def test_padded_rows_are_shared(self):
        a = np.arange(100 * 80, dtype=np.uint8).reshape(100, 80)
        roi = a[10:60, 5:45]  # rows 80 bytes apart, 40 pixels each
        with warnings.catch_warnings():
            warnings.simplefilter("error", cdff.CopyWarning)
            image = cdff.Image(roi)
        assert image.stride_bytes == 80
        assert np.shares_memory(image.array, a)
        np.testing.assert_array_equal(image.array, roi)

    def test_strided_pixels_are_copied_with_a_warning(self):
        a = np.arange(40 * 60, dtype=np.uint8).reshape(40, 60)
        with pytest.warns(cdff.CopyWarning, match="copied"):
            image = cdff.Image(a[:, ::2])
        assert not np.shares_memory(image.array, a)
        np.testing.assert_array_equal(image.array, a[:, ::2])
        with warnings.catch_warnings():
            warnings.simplefilter("error", cdff.CopyWarning)
            cdff.Image(a[:, ::2], copy=True)
        with pytest.raises(ValueError, match="cannot be shared"):
            cdff.Image(a[:, ::2], copy=False)

    def test_outlives_the_array_reference(self):
        image = cdff.Image(np.full((8, 8), 7, np.uint8))  # the only reference is the image's
        assert int(image.array.sum()) == 7 * 64

    def test_wrong_dtype_or_shape(self):
        with pytest.raises(TypeError, match=r"float64 array of shape \(4, 4\).*expected uint8"):
            cdff.Image(np.zeros((4, 4)))
        with pytest.raises(TypeError, match=r"shape \(4, 4, 2\)"):
            cdff.Image(np.zeros((4, 4, 2), np.uint8))

    def test_empty_image_is_invalid_input(self):
        image = cdff.Image(np.zeros((0, 0), np.uint8))
        with pytest.raises(cdff.InvalidInputError, match="empty"):
            image.validate()

    def test_camera_model(self):
        cam = cdff.CameraModel(640, 480, 500.0, 500.0, 320.0, 240.0)
        image = cdff.Image(np.zeros((480, 640), np.uint8), camera=cam)
        np.testing.assert_allclose(image.camera.matrix(), [[500, 0, 320], [0, 500, 240], [0, 0, 1]])
        np.testing.assert_allclose(cam.project([0.1, -0.2, 2.0]), [345.0, 190.0])


class TestDepthMap:
    def test_float_metres_shared(self):
        a = np.full((30, 40), 2.5, np.float32)
        depth = cdff.DepthMap(a)
        assert np.shares_memory(depth.array, a) and depth.meters_per_unit == 1.0

    def test_bad_scale_is_the_cxx_message(self):
        with pytest.raises(cdff.InvalidInputError,
                           match=r"meters_per_unit is -1; expected a finite value > 0"):
            cdff.DepthMap(np.ones((3, 3), np.uint16), meters_per_unit=-1.0)


class TestPointCloud:
    def test_n4_float32_is_shared_and_n3_view(self):
        a = np.random.default_rng(1).normal(size=(1000, 4)).astype(np.float32)
        with warnings.catch_warnings():
            warnings.simplefilter("error", cdff.CopyWarning)
            cloud = cdff.PointCloud(a, frame_id="lidar", stamp=3)
        assert len(cloud) == 1000
        assert np.shares_memory(cloud.points, a) and np.shares_memory(cloud.points4, a)
        np.testing.assert_array_equal(cloud.points, a[:, :3])
        assert cloud.points.shape == (1000, 3) and not cloud.points.flags.writeable

    def test_n3_is_copied_with_a_warning(self):
        a = np.random.default_rng(2).normal(size=(10, 3))
        with pytest.warns(cdff.CopyWarning, match=r"\(N, 4\) float32"):
            cloud = cdff.PointCloud(a)
        np.testing.assert_allclose(cloud.points, a.astype(np.float32))
        with pytest.raises(ValueError, match="copy=True"):
            cdff.PointCloud(a, copy=False)

    def test_fields(self):
        pts = np.zeros((5, 4), np.float32)
        intensity = np.arange(5, dtype=np.float32)
        ring = np.arange(5, dtype=np.uint16)
        cloud = cdff.PointCloud(pts, intensity=intensity, ring=ring)
        assert np.shares_memory(cloud.intensity, intensity) and np.shares_memory(cloud.ring, ring)
        with pytest.raises(cdff.InvalidInputError, match="5 points but 4 intensity values"):
            cdff.PointCloud(pts, intensity=np.zeros(4, np.float32))

    def test_bad_shapes_and_nan(self):
        with pytest.raises(ValueError, match=r"expected shape \(N, 3\) or \(N, 4\)"):
            cdff.PointCloud(np.zeros((5, 2), np.float32))
        with pytest.raises(TypeError, match="expected a real or integer array"):
            cdff.PointCloud(np.array([["a", "b", "c"]]))
        nan = np.zeros((3, 4), np.float32)
        nan[1, 2] = np.nan
        cloud = cdff.PointCloud(nan)  # kept as given: the DFN that reads it decides
        with pytest.raises(cdff.InvalidInputError, match=r"point 1 is \(0, 0, nan\)"):
            cloud.validate()
        with pytest.raises(cdff.InvalidInputError, match="no points"):
            cdff.PointCloud(np.zeros((0, 4), np.float32))


class TestMesh:
    def test_shared_and_sampled(self):
        v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
        t = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint32)
        mesh = cdff.TriangleMesh(v, t)
        assert np.shares_memory(mesh.vertices, v) and np.shares_memory(mesh.triangles, t)
        assert mesh.surface_area() == pytest.approx(1.5 + np.sqrt(3) / 2)
        cloud = mesh.sample_surface(500, seed=1)
        assert len(cloud) == 500 and cloud.normals.shape == (500, 3)

    def test_index_out_of_range(self):
        v = np.zeros((3, 3), np.float32)
        with pytest.raises(cdff.InvalidInputError):
            cdff.TriangleMesh(v, np.array([[0, 1, 7]], np.uint32))


class TestGeometry:
    def test_quaternion_order_and_matrix(self):
        half = np.sqrt(0.5)
        t = cdff.Transform([1.0, 2.0, 3.0], [0.0, 0.0, half, half], "a", "b")  # 90 deg about z
        np.testing.assert_allclose(t.apply(np.array([[1.0, 0.0, 0.0]])), [[1.0, 3.0, 3.0]],
                                   atol=1e-12)
        back = cdff.Transform.from_matrix(t.matrix, "a", "b")
        np.testing.assert_allclose(back.quaternion_xyzw, t.quaternion_xyzw, atol=1e-12)
        identity = t.compose(t.inverse())
        np.testing.assert_allclose(identity.matrix, np.eye(4), atol=1e-12)

    def test_frame_mismatch_and_non_rigid(self):
        a_T_b = cdff.Transform([0, 0, 0], [0, 0, 0, 1], "a", "b")
        c_T_d = cdff.Transform([0, 0, 0], [0, 0, 0, 1], "c", "d")
        with pytest.raises(cdff.Error):
            a_T_b * c_T_d
        with pytest.raises(cdff.InvalidInputError, match="not a rigid transform"):
            cdff.Transform.from_matrix(np.diag([2.0, 1.0, 1.0, 1.0]))
        bad = cdff.Transform([0, 0, np.nan], [0, 0, 0, 1])
        with pytest.raises(cdff.InvalidInputError):
            bad.validate()

    def test_pose_with_covariance(self):
        cov = np.diag([1e-4] * 3 + [1e-6] * 3)
        p = cdff.PoseWithCovariance(cdff.Transform([1, 0, 0], [0, 0, 0, 1]), cov)
        np.testing.assert_array_equal(p.covariance, cov)
        p.validate()


def test_every_registered_type_crosses_into_python():
    missing = [t for t in cdff.type_names() if cdff.python_type_of(t) is None]
    assert missing == []
    for name in cdff.type_names():
        python_type = cdff.python_type_of(name)
        if python_type.startswith("cdff."):
            assert hasattr(cdff, python_type[len("cdff."):]), name
