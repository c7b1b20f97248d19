//! `scripts/layers`: the import loops and upward arrows of every folder of the crates given
//! (each a crate directory with `src/` and, optionally, `floors.txt`). See `floors.rs`.

#[path = "scan.rs"]
mod scan;

#[path = "floors.rs"]
mod floors;

use std::path::Path;

fn main() {
    let mut total = (0, 0);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let suggest = args.iter().any(|a| a == "--suggest");
    for dir in args.iter().filter(|a| *a != "--suggest") {
        let src = Path::new(&dir).join("src");
        let floors_path = Path::new(&dir).join("floors.txt");
        let floors = match std::fs::read_to_string(&floors_path) {
            Ok(text) => floors::parse_floors(&text).unwrap_or_else(|e| {
                eprintln!("{}: {e}", floors_path.display());
                std::process::exit(2)
            }),
            Err(_) => Default::default(),
        };
        let all = floors::arrows(&src);
        if !suggest {
            println!("{dir}");
        }
        for folder in floors::folders(&src) {
            let here = if folder == "crate" { src.clone() } else { src.join(&folder) };
            let modules = floors::children(&here, folder == "crate");
            let mine: Vec<&floors::Arrow> = all.iter().filter(|a| a.folder == folder).collect();
            if suggest {
                println!("{}", floors::suggest(&folder, &mine, &modules));
                continue;
            }
            let fl = floors.get(&folder);
            let set = matches!(fl, Some(floors::Floors::Set(_)));
            let rep = floors::check_folder(&mine, &modules, fl.filter(|_| set));
            let what = match fl {
                Some(floors::Floors::Set(f)) => format!("{} floors", f.len()),
                Some(floors::Floors::Pending(n)) => format!("pending {n}"),
                None => "no floors".into(),
            };
            println!(
                "  {folder:<24} {:>3} modules {:>4} arrows {:>3} loops {:>3} upward  ({what})",
                modules.len(),
                rep.arrows,
                rep.loops.len(),
                rep.upward.len()
            );
            total.0 += rep.loops.len();
            total.1 += rep.upward.len();
            for l in &rep.loops {
                println!("      loop: {}", l.join(" <-> "));
            }
            for (arrow, places) in &rep.upward {
                let more = if places.len() > 2 { format!(" (+{})", places.len() - 2) } else { String::new() };
                println!("      upward: {arrow:<34} {}{more}", places[..places.len().min(2)].join(", "));
            }
            for m in &rep.misplaced {
                println!("      floors: {m}");
            }
        }
    }
    if !suggest {
        println!("total: {} loops, {} upward arrows", total.0, total.1);
    }
}
