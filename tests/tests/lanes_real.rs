//! Lane graphs from the real KITTI trajectories in ../shared/data (skipped when absent):
//! connected, covering every pose within 10 m, with the junction counts printed.

use ingest::hierarchy::lanes::{LaneConfig, extract_lanes};
use ingest::sources::kitti::{ground_trajectory, read_calib, read_poses};

#[test]
fn real_kitti_lane_graphs() {
    let Some(data) = opengraph_tests::shared_data() else {
        eprintln!("skipping: ../shared/data is absent");
        return;
    };
    for seq in ["00", "03", "05", "08"] {
        let dir = data.join("kitti/sequences").join(seq);
        let poses = read_poses(&dir.join("poses.txt")).unwrap();
        let calib = read_calib(&dir.join("calib.txt")).unwrap();
        let traj = ground_trajectory(&poses, Some(&calib));
        let t = std::time::Instant::now();
        let g = extract_lanes(&traj, &LaneConfig::default()).unwrap();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let kinds = g.kind_counts();
        let total_m: f64 = g.edges.iter().map(|e| e.length_m).sum();
        eprintln!(
            "seq {seq}: {} poses, {} nodes {:?}, {} edges, {:.0} m of lanes ({ms:.0} ms, debug build)",
            poses.len(),
            g.nodes.len(),
            kinds
                .iter()
                .map(|(k, n)| format!("{}={n}", k.as_str()))
                .collect::<Vec<_>>(),
            g.edges.len(),
            total_m
        );
        assert!(g.is_connected(), "seq {seq}: lane graph is not connected");
        let worst = traj
            .iter()
            .enumerate()
            .map(|(i, p)| (i, g.distance_to_edges(*p)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(
            worst.1 <= 10.0,
            "seq {seq}: pose {} is {:.1} m from every lane edge",
            worst.0,
            worst.1
        );
        // every pose is on some edge's frame list
        let mut covered = vec![false; poses.len()];
        for e in &g.edges {
            for f in &e.frames {
                covered[*f as usize] = true;
            }
        }
        let missing = covered.iter().filter(|c| !**c).count();
        assert!(
            missing * 100 <= poses.len(),
            "seq {seq}: {missing} poses belong to no edge"
        );
        assert!(g.nodes.len() >= 2);
    }
}
