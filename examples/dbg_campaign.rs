use magswarm::lab::presets::Campaign;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args[1].clone();
    let strength: f64 = args[2].parse().unwrap();
    let seed: u64 = args[3].parse().unwrap();
    let effects: Vec<(&str, f64)> = if name == "none" || name == "bump" {
        vec![]
    } else {
        name.split('+').map(|n| (n, strength)).collect()
    };
    let mut c = Campaign::seed_grid(&effects, seed).expect("campaign");
    if name == "bump" {
        c.scenario.foreign = vec![magswarm::lab::Foreign::Bump {
            z_mm: 13.5,
            f_hz: 4.0,
            width_z_mm: 2.5,
            width_f_hz: 1.2,
            amp_mm: [0.3 * strength, 1.0 * strength],
        }];
    }
    let log = c.log("train.csv").expect("lab log");
    log.write(std::path::Path::new(&args[4])).unwrap();
}
