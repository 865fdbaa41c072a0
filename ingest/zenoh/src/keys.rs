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

/// The key to subscribe to `topic` with: any type and type hash, so that a message of
/// another type on the topic is seen (and counted, see [`ros_type_of`]) rather than missed.
pub fn ros_subscription(domain_id: u32, topic: &str) -> String {
    format!("{domain_id}/{}/*/*", topic.trim_start_matches('/'))
}

/// The DDS type name in `key`, a sample's key under [`ros_subscription`] of `topic`.
pub fn ros_type_of<'k>(key: &'k str, domain_id: u32, topic: &str) -> Option<&'k str> {
    let rest = key.strip_prefix(&format!("{domain_id}/{}/", topic.trim_start_matches('/')))?;
    rest.split('/').next()
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
        assert_eq!(ros_subscription(3, "/kitti/velo"), "3/kitti/velo/*/*");
        let key = ros_topic(3, "/kitti/velo", &POINT_CLOUD2);
        assert_eq!(
            ros_type_of(&key, 3, "/kitti/velo"),
            Some("sensor_msgs::msg::dds_::PointCloud2_")
        );
        assert_eq!(ros_type_of(&key, 4, "/kitti/velo"), None);
        assert!(is_chunk("city-1.a") && !is_chunk("a/b") && !is_chunk("*") && !is_chunk(""));
        assert_eq!(map_prefix("city", Some("north")), "opengraph/city/north");
    }
}
