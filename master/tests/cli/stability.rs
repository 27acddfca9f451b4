//! `master stability`: a variant whose pose is infeasible (its form-finding, slow to prove it,
//! runs inside the first of its cells while the other variants' cells run) gives the same map
//! on one thread as on several.

use crate::master;

#[test]
fn an_infeasible_variant_gives_the_same_map_serial_and_parallel() {
    let scene = crate::common::scene_file("lt50m_B.toml", "stability-infeasible", |_| {});
    let scene = scene.display().to_string();
    let base = std::env::temp_dir().join(format!("cli-stability-{}", std::process::id()));
    let mut csvs = Vec::new();
    for jobs in ["1", "3"] {
        let dir = base.join(jobs);
        let out = master(&[
            "stability",
            "--scene",
            &scene,
            "--schemes",
            "ijcsa,gauss-seidel",
            "--ratios",
            "1,10",
            "--dts",
            "0.02,0.01",
            "--t-end",
            "0.2",
            "--jobs",
            jobs,
            "--quiet",
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        csvs.push(std::fs::read_to_string(dir.join("stability.csv")).unwrap());
    }
    assert_eq!(csvs[0], csvs[1]);
    let rows: Vec<&str> = csvs[0].lines().skip(1).collect();
    assert_eq!(rows.len(), 8);
    for row in rows {
        let infeasible = row.contains(",10,");
        assert_eq!(row.contains(",infeasible,,\"a cable would have to push\""), infeasible, "{row}");
    }
    std::fs::remove_dir_all(&base).unwrap();
}
