//! Prints a job posted without the read-back: `cargo run -p cnc402-post --example
//! post_unproven -- TARGET JOB`, to look into a refusal of `cnc402 post`.
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(target), Some(job)) = (args.get(1), args.get(2)) else {
        eprintln!("usage: post_unproven TARGET JOB");
        std::process::exit(64);
    };
    let cfg = cnc402_config::MachineConfig::load(cnc402_config::DEFAULT_PATH).expect("config");
    let text = std::fs::read_to_string(job).expect("job");
    let target = cnc402_post::Target::from_name(target).expect("target");
    match cnc402_post::post_unproven(&cfg, job, &text, target) {
        Ok(p) => print!("{p}"),
        Err(e) => eprintln!("{e}"),
    }
}
