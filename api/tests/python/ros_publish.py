"""Publishes ROS 2 sensor messages to `opengraph serve --zenoh` with code no one in this
project wrote: messages serialised by PyPI `rosbags` (CDR, ROS 2 Jazzy types and type hashes),
sent by PyPI `eclipse-zenoh` on rmw_zenoh key expressions. Then asks the server, through the
same Python zenoh session, what it mapped.

usage: ros_publish.py ENDPOINT     (e.g. tcp/127.0.0.1:17447)

A box of LiDAR points 10 m ahead of a standing robot, three frames, each with a
`sensor_msgs/PointCloud2`, a `nav_msgs/Odometry`, a `sensor_msgs/CameraInfo` and a detection
of the box ("a red post box") in a `std_msgs/String`. The camera looks along the LiDAR's x
axis (cam_from_velo: x_cam = -y, y_cam = -z, z_cam = x), P = [[100, 0, 100, 0], [0, 100, 50, 0],
[0, 0, 1, 0]], image 200 x 100. Prints one JSON line: what was published and the answers.
"""

import json
import sys
import time

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_typestore

ENDPOINT = sys.argv[1]
TS = get_typestore(Stores.ROS2_JAZZY)
T = TS.types
W, H = 200, 100


def key(topic, typename):
    dds = typename.replace("/msg/", "::msg::dds_::") + "_"
    return f"0/{topic}/{dds}/{TS.hash_rihs01(typename)}"


def header(sec, frame):
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=0), frame_id=frame
    )


def cloud(sec):
    ys, zs = np.meshgrid(np.linspace(-1.0, 1.0, 21), np.linspace(-0.5, 1.5, 21))
    pts = np.stack(
        [np.full(ys.size, 10.0), ys.ravel(), zs.ravel(), np.full(ys.size, 0.5)], axis=1
    ).astype("<f4")
    field = T["sensor_msgs/msg/PointField"]
    fields = [field(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")]
    fields.append(field(name="intensity", offset=12, datatype=7, count=1))
    msg = T["sensor_msgs/msg/PointCloud2"](
        header=header(sec, "velodyne"),
        height=1,
        width=len(pts),
        fields=fields,
        is_bigendian=False,
        point_step=16,
        row_step=16 * len(pts),
        data=np.frombuffer(pts.tobytes(), dtype=np.uint8),
        is_dense=True,
    )
    return bytes(TS.serialize_cdr(msg, "sensor_msgs/msg/PointCloud2"))


def odometry(sec):
    g = T
    msg = g["nav_msgs/msg/Odometry"](
        header=header(sec, "odom"),
        child_frame_id="velodyne",
        pose=g["geometry_msgs/msg/PoseWithCovariance"](
            pose=g["geometry_msgs/msg/Pose"](
                position=g["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=g["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            ),
            covariance=np.zeros(36),
        ),
        twist=g["geometry_msgs/msg/TwistWithCovariance"](
            twist=g["geometry_msgs/msg/Twist"](
                linear=g["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                angular=g["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            ),
            covariance=np.zeros(36),
        ),
    )
    return bytes(TS.serialize_cdr(msg, "nav_msgs/msg/Odometry"))


def camera_info(sec):
    p = np.array([100.0, 0, 100, 0, 0, 100, 50, 0, 0, 0, 1, 0])
    msg = T["sensor_msgs/msg/CameraInfo"](
        header=header(sec, "camera"),
        height=H,
        width=W,
        distortion_model="plumb_bob",
        d=np.zeros(5),
        k=np.array([100.0, 0, 100, 0, 100, 50, 0, 0, 1]),
        r=np.eye(3).ravel(),
        p=p,
        binning_x=0,
        binning_y=0,
        roi=T["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        ),
    )
    return bytes(TS.serialize_cdr(msg, "sensor_msgs/msg/CameraInfo"))


def detections(sec):
    # the box projects to u in [90, 110], v in [35, 55]; the mask takes a margin
    mask = np.zeros((H, W), dtype=bool)
    mask[30:60, 85:115] = True
    flat = mask.T.ravel()  # column-major, as COCO RLE
    counts, run, value = [], 0, False
    for m in flat:
        if m == value:
            run += 1
        else:
            counts.append(run)
            run, value = 1, m
    counts.append(run)
    det = {
        "format": "opengraph-detections",
        "version": 1,
        "frame": sec,
        "stamp": {"sec": sec, "nanosec": 0},
        "image": {"width": W, "height": H},
        "producer": "detector",
        "detections": [
            {
                "mask": {"size": [H, W], "counts": counts},
                "bbox": [85, 30, 30, 30],
                "score": 0.9,
                "tags": ["post box"],
                "caption": "a red post box",
            }
        ],
    }
    msg = T["std_msgs/msg/String"](data=json.dumps(det))
    return bytes(TS.serialize_cdr(msg, "std_msgs/msg/String"))


def main():
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("connect/endpoints", json.dumps([ENDPOINT]))
    session = zenoh.open(conf)
    pubs = {
        "cloud": session.declare_publisher(key("velodyne_points", "sensor_msgs/msg/PointCloud2")),
        "odom": session.declare_publisher(key("odom", "nav_msgs/msg/Odometry")),
        "camera": session.declare_publisher(
            key("camera/camera_info", "sensor_msgs/msg/CameraInfo")
        ),
        "detections": session.declare_publisher(key("detections", "std_msgs/msg/String")),
    }
    deadline = time.time() + 30
    while not pubs["cloud"].matching_status.matching:
        if time.time() > deadline:
            raise SystemExit("no subscriber to the clouds after 30 s")
        time.sleep(0.05)
    sent = 0
    for sec in (100, 101, 102):
        pubs["odom"].put(odometry(sec))
        pubs["camera"].put(camera_info(sec))
        pubs["cloud"].put(cloud(sec))
        pubs["detections"].put(detections(sec))
        sent += 1
    # what the server mapped, asked through zenoh as well
    status, found = None, None
    deadline = time.time() + 60
    while time.time() < deadline:
        replies = list(session.get("opengraph/live/status", timeout=5.0))
        status = json.loads(replies[0].ok.payload.to_bytes()) if replies else None
        if status and status["live"]["frames_mapped"] == sent and status["live"]["commits"] > 0:
            break
        time.sleep(0.2)
    query = {"tool": "find_objects", "args": {"text": "a post box", "k": 1}}
    replies = list(session.get("opengraph/live/query", payload=json.dumps(query), timeout=10.0))
    if replies and replies[0].ok is not None:
        found = json.loads(replies[0].ok.payload.to_bytes())
    session.close()
    print(json.dumps({"sent": sent, "status": status, "found": found}))


main()
