//! Fuzzes the hest-style argument parser, including `@file` expansion: the input is
//! split into a response file and the command line.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[allow(dead_code)]
#[path = "../../rendr/src/args.rs"]
mod args;

use args::{def, flag, opt, req, Arity, CmdSpec, Pos};

static SPEC: CmdSpec = CmdSpec {
    name: "fuzz",
    about: "fuzz",
    info: "",
    response_files: true,
    opts: &[
        req(&["fr"], 3, "x y z", "a"),
        def(&["s", "-planesep"], 1, "0.1", "s", "b"),
        opt(&["o"], 1, "f", "c"),
        flag(&["ortho"], "d"),
        args::Opt { names: &["v"], arity: Arity::Var(1), default: None, required: false, meta: "v", help: "e" },
    ],
    pos: &[Pos { name: "p", arity: Arity::Var(0), help: "f" }],
};

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else { return };
    let (file, line) = s.split_once('\u{1}').unwrap_or(("", s));
    let path = std::env::temp_dir().join(format!("rendr-fuzz-args-{}.txt", std::process::id()));
    if std::fs::write(&path, file).is_err() {
        return;
    }
    let mut argv: Vec<String> = line.split_whitespace().map(str::to_string).collect();
    argv.push(format!("@{}", path.display()));
    if let Ok(a) = args::parse(&SPEC, &argv) {
        let _ = a.get_arr::<f64, 3>("fr");
        let _ = a.get::<f64>("s");
        let _ = a.get_str("o");
        let _ = a.flag("ortho");
        let _ = a.words("v");
        let _ = a.pos(0);
    }
    let _ = args::usage(&SPEC);
    let _ = args::help(&SPEC);
});
