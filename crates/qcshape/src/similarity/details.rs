//! The per-pose distances of a run as CSV (`qcshape similarity --details`), and the pairs whose
//! geodesics did not converge, named.

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

/// The pairs of a run whose geodesics did not all converge ([`PairDistance::converged`]): their
/// distances are what the solver reached when it stopped, an upper bound of the geodesic length,
/// and enter the matrix as they are; the details CSV marks each of their rows
/// `converged=false`. The message names them (the first five) so that none is taken silently.
#[derive(Debug, Clone, PartialEq)]
pub struct Unconverged {
    /// The unconverged pairs, by name, in row order.
    pub pairs: Vec<(String, String)>,
    /// The pairs of the run.
    pub total: usize,
}

impl Unconverged {
    /// The unconverged pairs of `pairs` (`names` name the deformations), or `None` when every
    /// pair converged.
    pub fn of(names: &[String], pairs: &[PairDistance]) -> Option<Unconverged> {
        let bad: Vec<(String, String)> = pairs
            .iter()
            .filter(|p| !p.converged)
            .map(|p| (names[p.i].clone(), names[p.j].clone()))
            .collect();
        (!bad.is_empty()).then_some(Unconverged {
            pairs: bad,
            total: pairs.len(),
        })
    }
}

impl std::fmt::Display for Unconverged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shown: Vec<String> = self
            .pairs
            .iter()
            .take(5)
            .map(|(a, b)| format!("{a} / {b}"))
            .collect();
        let more = self.pairs.len().saturating_sub(5);
        write!(
            f,
            "{} of {} pair(s) have a geodesic that did not converge: {}{}; their distances are upper \
             bounds (the path where the solver stopped), in the matrix as computed and marked \
             converged=false in --details",
            self.pairs.len(),
            self.total,
            shown.join(", "),
            if more > 0 {
                format!(" (+{more} more)")
            } else {
                String::new()
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(i: usize, j: usize, converged: bool) -> PairDistance {
        PairDistance {
            i,
            j,
            distance: 1.0,
            per_pose: vec![0.0, 1.0],
            per_pose_energy: None,
            converged,
            iterations: 1,
            seconds: 0.0,
        }
    }

    #[test]
    fn unconverged_pairs_are_flagged_in_the_details_and_named() {
        let names: Vec<String> = ["a", "b", "c"].map(String::from).to_vec();
        let pairs = [pair(0, 1, true), pair(0, 2, false), pair(1, 2, true)];
        let csv = details_csv(&names, &pairs);
        assert!(csv.contains("a,c,1,1.0,false,"), "{csv}");
        assert!(csv.contains("a,b,1,1.0,true,"), "{csv}");
        let u = Unconverged::of(&names, &pairs).unwrap();
        assert_eq!(u.pairs, [("a".to_string(), "c".to_string())]);
        assert!(
            u.to_string()
                .starts_with("1 of 3 pair(s) have a geodesic that did not converge: a / c;"),
            "{u}"
        );
        assert_eq!(Unconverged::of(&names, &pairs[..1]), None);
    }
}
