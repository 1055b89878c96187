"""Real input end to end: ROS 1/2 bags as a frame source (written here with rosbags' writers),
and ``python -m redservo.vision SOURCE --tags`` printing ids, corners and poses per frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from redservo.camera import Camera
from redservo.scene import Scene, Static, Tag
from redservo.spatial import make_transform

cv2 = pytest.importorskip("cv2", reason="the image pipeline needs redservo[vision]")
pytest.importorskip("rosbags", reason="reading bags needs redservo[bags]")

from rosbags.typesys import Stores, get_typestore  # noqa: E402

from redservo.vision.__main__ import main  # noqa: E402
from redservo.vision.bags import bag_camera, bag_frames, bag_joint_states  # noqa: E402
from redservo.vision.render import Renderer, RenderOptions  # noqa: E402
from redservo.vision.sources import frames  # noqa: E402

CAM = Camera(px=300.0, py=300.0, u0=160.0, v0=120.0, width=320, height=240, k1=-0.05)
POSES = [
    make_transform(t=[0.01 * k, 0.0, 0.3], rotvec=[np.pi + 0.1, 0.05 * k, 0.2]) for k in range(3)
]


def _images() -> list[np.ndarray]:
    r = Renderer(CAM, RenderOptions(noise_px=1.0, blur_px=0.5))  # the camera's distortion
    return [
        r.render(Scene([Tag("tag", size=0.1, tag_id=7, trajectory=Static(P))]), np.eye(4))
        for P in POSES
    ]


def _messages(ts, images: list[np.ndarray], encoding: str, ros1: bool):
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]
    hdr = {"stamp": Time(sec=0, nanosec=0), "frame_id": "camera"}
    if ros1:
        hdr["seq"] = 0
    Header = T["std_msgs/msg/Header"]
    Image = T["sensor_msgs/msg/Image"]
    out = []
    for img in images:
        data = img if encoding == "mono8" else cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
        out.append(
            Image(
                header=Header(**hdr),
                height=img.shape[0],
                width=img.shape[1],
                encoding=encoding,
                is_bigendian=0,
                step=data.shape[1] * (1 if encoding == "mono8" else 3),
                data=np.ascontiguousarray(data).ravel(),
            )
        )
    Roi = T["sensor_msgs/msg/RegionOfInterest"]
    k = [CAM.px, 0.0, CAM.u0 - 0.5, 0.0, CAM.py, CAM.v0 - 0.5, 0.0, 0.0, 1.0]
    arrays = {
        "d": np.array(CAM.distortion),
        "k": np.array(k),
        "r": np.eye(3).ravel(),
        "p": np.zeros(12),
    }
    if ros1:
        arrays = {key.upper(): v for key, v in arrays.items()}
    info = T["sensor_msgs/msg/CameraInfo"](
        header=Header(**hdr),
        height=CAM.height,
        width=CAM.width,
        distortion_model="plumb_bob",
        binning_x=0,
        binning_y=0,
        roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
        **arrays,
    )
    js = T["sensor_msgs/msg/JointState"](
        header=Header(**hdr),
        name=["j0", "j1"],
        position=np.array([0.1, 0.2]),
        velocity=np.zeros(2),
        effort=np.zeros(2),
    )
    return out, info, js


def _write(
    path: Path, images: list[np.ndarray], *, ros1: bool, encoding: str, storage: str | None = None
) -> Path:
    if ros1:
        from rosbags.rosbag1 import Writer as W1

        ts = get_typestore(Stores.ROS1_NOETIC)
        writer, ser = W1(path), ts.serialize_ros1
    else:
        from rosbags.rosbag2 import Writer as W2

        ts = get_typestore(Stores.ROS2_HUMBLE)
        from rosbags.rosbag2 import StoragePlugin

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer, ser = W2(path, version=9, storage_plugin=plugin), ts.serialize_cdr
    imgs, info, js = _messages(ts, images, encoding, ros1)
    with writer as w:
        ci = w.add_connection("/camera/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
        im = w.add_connection("/camera/image_raw", "sensor_msgs/msg/Image", typestore=ts)
        jc = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=ts)
        w.write(ci, 1, ser(info, "sensor_msgs/msg/CameraInfo"))
        for k, msg in enumerate(imgs):
            w.write(im, 10 + k * 33_000_000, ser(msg, "sensor_msgs/msg/Image"))
            w.write(jc, 11 + k * 33_000_000, ser(js, "sensor_msgs/msg/JointState"))
    return path


@pytest.mark.parametrize(("ros1", "encoding"), [(False, "mono8"), (True, "bgr8")])
def test_bag_frames_camera_info_and_joint_states(tmp_path: Path, ros1: bool, encoding: str) -> None:
    images = _images()
    bag = _write(tmp_path / ("run.bag" if ros1 else "run"), images, ros1=ros1, encoding=encoding)
    got = list(frames(str(bag)))
    assert len(got) == 3
    for a, b in zip(got, images):
        assert np.abs(a.astype(int) - b.astype(int)).max() <= 1  # bgr8 -> gray rounds
    assert bag_camera(bag) == CAM
    assert len(list(bag_frames(bag, max_frames=2))) == 2
    names, t, q = bag_joint_states(bag)
    assert names == ["j0", "j1"] and q.shape == (3, 2) and np.all(np.diff(t) > 0)


def test_cli_prints_tags_and_poses_from_a_bag(tmp_path: Path, capsys) -> None:
    bag = _write(tmp_path / "run", _images(), ros1=False, encoding="mono8")
    assert main([str(bag), "--tags", "36h11", "--tag-size", "0.1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and all(
        ln.startswith(f"frame {k} tag 7: corners") for k, ln in enumerate(lines)
    )
    for ln, P in zip(lines, POSES):
        t = [float(v) for v in ln.split("| t ")[1].split(" m")[0].split()]
        assert np.linalg.norm(np.array(t) - P[:3, 3]) < 2e-3  # the bag's camera_info (k1) used


def test_cli_with_a_camera_file_and_errors(tmp_path: Path, capsys) -> None:
    from redservo.calibration.files import save_camera

    folder = tmp_path / "shots"
    folder.mkdir()
    for k, img in enumerate(_images()[:2]):
        cv2.imwrite(str(folder / f"{k:02d}.png"), img)
    cam = save_camera(tmp_path / "cam.yaml", CAM)
    assert main([str(folder), "--tags", "tag36h11", "--tag-size", "0.1", "--camera", str(cam)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [ln.split(":")[0] for ln in out] == ["frame 0 tag 7", "frame 1 tag 7"]
    assert main([str(folder), "--tags", "36h12"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown tag family" in err
    assert main([str(folder), "--tags", "25h9"]) == 0
    assert capsys.readouterr().out.splitlines() == ["frame 0: no tag", "frame 1: no tag"]


def test_tag_feature_source_feeds_the_servo_loop(tmp_path: Path) -> None:
    """The frames of a bag as a hardware FeatureSource: corners and pose features per frame."""
    from redservo.features import PointFeature, PoseTranslation
    from redservo.hardware import FeatureSource
    from redservo.task import TaskTerm, VisualTask
    from redservo.vision.tag_source import TagFeatureSource

    tag = Tag("tag", size=0.1, tag_id=7)
    bag = _write(tmp_path / "run", _images(), ros1=False, encoding="mono8")
    terms = [TaskTerm(PointFeature(p), "tag") for p in tag.points]
    terms.append(TaskTerm(PoseTranslation("cMo"), "tag"))
    task = VisualTask.from_desired_poses(terms, {"tag": POSES[0]})
    src = TagFeatureSource(task, {"tag": tag}, str(bag), bag_camera(bag))
    assert isinstance(src, FeatureSource)
    for k, P in enumerate(POSES):
        m = src.measure(0.1 * k)
        assert m is not None and m.t_measured == pytest.approx(0.1 * k)
        truth, _ = task.measure(
            Scene([Tag("tag", size=0.1, tag_id=7, trajectory=Static(P))]), np.eye(4), 0.0
        )
        np.testing.assert_allclose(m.s[:8], truth[:8], atol=1e-3)  # normalized: 0.3 px at 300 px
        np.testing.assert_allclose(m.s[8:], P[:3, 3], atol=2e-3)  # m
        np.testing.assert_allclose(
            m.inv_depth[0], [1.0 / (P @ [-0.05, -0.05, 0.0, 1.0])[2]], rtol=0.02
        )
    assert src.measure(1.0) is None and "no more frames" in src.reason


# -- damaged bags and bad image messages: one clear error naming the bag (issue 32) ------------


def _damage(bag: Path, how: str) -> Path:
    """``bag`` (a ROS 1 file or a ROS 2 folder) truncated, bit-flipped or with bad metadata."""
    target = bag if bag.is_file() else next(p for p in bag.iterdir() if p.suffix != ".yaml")
    data = bytearray(target.read_bytes())
    if how == "truncated":
        data = data[: len(data) // 2]
    elif how == "flipped":
        i = len(data) // 2
        data[i : i + 8] = b"\xff" * 8
    elif how == "metadata":
        (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [1, 2")
    target.write_bytes(bytes(data))
    return bag


@pytest.mark.parametrize(
    ("ros1", "storage", "how"),
    [
        (True, None, "truncated"),
        (False, "sqlite3", "truncated"),
        (False, "sqlite3", "flipped"),
        (False, "sqlite3", "metadata"),
        (False, "mcap", "truncated"),
    ],
)
def test_a_damaged_bag_is_one_clear_error(
    tmp_path: Path, ros1: bool, storage: str | None, how: str, capsys
) -> None:
    from redservo.errors import ConfigurationError

    images = [np.full((24, 32), 100, np.uint8)] * 40  # a bag large enough to damage inside
    name = "run.bag" if ros1 else "run"
    bag = _damage(
        _write(tmp_path / name, images, ros1=ros1, encoding="mono8", storage=storage), how
    )
    with pytest.raises(ConfigurationError, match="damaged or truncated") as info:
        list(frames(str(bag)))
    assert str(bag) in str(info.value)
    for argv in ([str(bag)], [str(bag), "--tags", "36h11"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert str(bag) in err and "damaged or truncated" in err and "internal" not in err


def _bad_image(ts: object, ros1: bool, how: str) -> tuple[str, object]:
    T = ts.types  # type: ignore[attr-defined]
    hdr = {"stamp": T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), "frame_id": "c"}
    if ros1:
        hdr["seq"] = 0
    header = T["std_msgs/msg/Header"](**hdr)
    if how == "compressed":
        msg = T["sensor_msgs/msg/CompressedImage"](
            header=header, format="png", data=np.frombuffer(b"not a png at all", np.uint8)
        )
        return "sensor_msgs/msg/CompressedImage", msg
    h, w, step, n, enc = {
        "short": (24, 32, 32, 100, "mono8"),
        "step": (24, 32, 16, 24 * 32, "mono8"),
        "empty": (0, 32, 32, 0, "mono8"),
        "encoding": (24, 32, 32, 24 * 32, "yuv422"),
    }[how]
    msg = T["sensor_msgs/msg/Image"](
        header=header,
        height=h,
        width=w,
        encoding=enc,
        is_bigendian=0,
        step=step,
        data=np.zeros(n, np.uint8),
    )
    return "sensor_msgs/msg/Image", msg


@pytest.mark.parametrize("ros1", [True, False])
@pytest.mark.parametrize(
    ("how", "message"),
    [
        ("short", "100 bytes of data, fewer than height x step"),
        ("step", "step 16 bytes is shorter than a row"),
        ("empty", "an image of 32 x 0 pixels; both must be at least 1"),
        ("encoding", "image encoding 'yuv422' is not supported"),
        ("compressed", "cannot decode the compressed image"),
    ],
)
def test_a_bad_image_message_names_the_bag_topic_and_index(
    tmp_path: Path, ros1: bool, how: str, message: str, capsys
) -> None:
    if ros1:
        from rosbags.rosbag1 import Writer as W1

        ts = get_typestore(Stores.ROS1_NOETIC)
        path, writer, ser = tmp_path / "bad.bag", W1(tmp_path / "bad.bag"), ts.serialize_ros1
    else:
        from rosbags.rosbag2 import Writer as W2

        ts = get_typestore(Stores.ROS2_HUMBLE)
        path, writer, ser = tmp_path / "bad", W2(tmp_path / "bad", version=9), ts.serialize_cdr
    msgtype, msg = _bad_image(ts, ros1, how)
    good = ts.types["sensor_msgs/msg/CompressedImage" if how == "compressed" else msgtype]
    with writer as w:
        c = w.add_connection("/cam", msgtype, typestore=ts)
        if how != "compressed":
            ok = good(
                header=msg.header,
                height=24,
                width=32,
                encoding="mono8",
                is_bigendian=0,
                step=32,
                data=np.zeros(24 * 32, np.uint8),
            )
            w.write(c, 1, ser(ok, msgtype))
        w.write(c, 2, ser(msg, msgtype))
    index = 0 if how == "compressed" else 1
    assert main([str(path)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"{path}: topic /cam, message {index}: {message}" in err, err
