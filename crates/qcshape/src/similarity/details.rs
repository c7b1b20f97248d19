//! The per-pose distances of a run as CSV (`qcshape similarity --details`).

use super::types::PairDistance;

/// The per-pose distances of `pairs` as CSV: header
/// `a,b,pose,distance,converged,geometric_energy,regularizer_energy,regularizer_share`, one
/// row per pair and pose `k` with `dis(M_k, N_k)` at full precision, the energy split of its
/// path ([`PairDistance::per_pose_energy`]) and the pair's regularizer share
/// ([`PairDistance::regularizer_share`], the same on every row of a pair); the three energy
/// fields are empty when the parts are unknown (tangent mode, old journals). `names` (n) name
/// the deformations (quoted when they hold a comma, a quote or a line break).
pub fn details_csv(names: &[String], pairs: &[PairDistance]) -> String {
    fn field(s: &str) -> String {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    }
    let mut text =
        String::from("a,b,pose,distance,converged,geometric_energy,regularizer_energy,regularizer_share\n");
    for p in pairs {
        let share = p.regularizer_share();
        for (k, d) in p.per_pose.iter().enumerate() {
            let parts = match (p.per_pose_energy.as_ref().and_then(|e| e.get(k)), share) {
                (Some([g, r]), Some(s)) => format!("{g:?},{r:?},{s:?}"),
                _ => ",,".to_string(),
            };
            text.push_str(&format!(
                "{},{},{k},{d:?},{},{parts}\n",
                field(&names[p.i]),
                field(&names[p.j]),
                p.converged
            ));
        }
    }
    text
}
