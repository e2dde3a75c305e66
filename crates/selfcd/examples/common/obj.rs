//! Shared by the examples that read mesh files (scaling, prof, queries, sensor_sweep).

/// Reads the `v` and `f` lines of an OBJ file (polygons fanned into triangles).
pub fn read_obj(path: &str) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).expect("readable OBJ file");
    let (mut v, mut f) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.take(3).map(|x| x.parse().expect("number")).collect();
                v.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .map(|x| x.split('/').next().unwrap().parse::<u32>().expect("index") - 1)
                    .collect();
                for k in 1..idx.len() - 1 {
                    f.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, f)
}
