//! Key expressions: rmw_zenoh's for ROS 2 topics, OpenGraph's for a served map.
//!
//! rmw_zenoh names a topic's samples `<domain_id>/<topic>/<DDS type>/<type hash>` (the topic
//! without its leading slash); a subscriber puts `*` in the hash slot so it takes any
//! version of the type. OpenGraph serves a map under `opengraph/<map>` (or
//! `opengraph/<map>/<region>` for one region of a sharded map): `…/events`, `…/query`,
//! `…/graph`.

use ingest::sources::ros::RosType;

/// The key a ROS 2 node on rmw_zenoh publishes `topic` of type `ty` under.
pub fn ros_topic(domain_id: u32, topic: &str, ty: &RosType) -> String {
    format!(
        "{domain_id}/{}/{}/{}",
        topic.trim_start_matches('/'),
        ty.dds,
        ty.hash
    )
}

/// The key to subscribe to `topic` of type `ty` with (any type hash).
pub fn ros_subscription(domain_id: u32, topic: &str, ty: &RosType) -> String {
    format!("{domain_id}/{}/{}/*", topic.trim_start_matches('/'), ty.dds)
}

/// Whether `name` may be a map or region chunk of a key: letters, digits, `_`, `-`, `.`.
pub fn is_chunk(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 128
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
}

/// `opengraph/<map>` or `opengraph/<map>/<region>`.
pub fn map_prefix(map: &str, region: Option<&str>) -> String {
    match region {
        Some(r) => format!("opengraph/{map}/{r}"),
        None => format!("opengraph/{map}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ingest::sources::ros::POINT_CLOUD2;

    #[test]
    fn rmw_zenoh_keys() {
        assert_eq!(
            ros_topic(0, "/velodyne_points", &POINT_CLOUD2),
            "0/velodyne_points/sensor_msgs::msg::dds_::PointCloud2_/RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5"
        );
        assert_eq!(
            ros_subscription(3, "kitti/velo", &POINT_CLOUD2),
            "3/kitti/velo/sensor_msgs::msg::dds_::PointCloud2_/*"
        );
        assert!(is_chunk("city-1.a") && !is_chunk("a/b") && !is_chunk("*") && !is_chunk(""));
        assert_eq!(map_prefix("city", Some("north")), "opengraph/city/north");
    }
}
