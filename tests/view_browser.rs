//! The toolpath page in a real headless browser (Debian's `chromium`): load the page written
//! by `cnc402 view`, click a known point of the path, read the block the page names. The
//! click is a `click` MouseEvent dispatched on the canvas at the point's screen position (the
//! page's `#pick=X,Y,Z` hook), so it goes through the same listener and picking code as a
//! user's click; `--dump-dom` returns the page with the picked block in `#picked`. Also the
//! `cnc402 run --plot` SVG of a run of several channels, opened in a frame as a file: where
//! the browser lays out its sections and texts.
//!
//! Needs `chromium` (CI installs it: `.ci/run`). Without it the tests fail, saying so; a
//! developer without a browser may set `CNC402_SKIP_BROWSER_TESTS=1` to skip them.
//! `CNC402_CHROMIUM=/path/to/chrome` chooses the browser.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A guard against a browser that never exits (not a speed requirement).
const BROWSER_HANG_GUARD: Duration = Duration::from_secs(300);

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CNC402_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for dir in std::env::split_paths(&path) {
        for name in ["chromium", "chromium-browser", "google-chrome"] {
            let p = dir.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// The browser, or `None` when the developer asked to skip; panics with what to do otherwise.
fn browser_or_skip() -> Option<PathBuf> {
    match chromium() {
        Some(p) => Some(p),
        None if std::env::var_os("CNC402_SKIP_BROWSER_TESTS").is_some_and(|v| v == "1") => {
            eprintln!("skipped: no chromium and CNC402_SKIP_BROWSER_TESTS=1");
            None
        }
        None => panic!(
            "the toolpath page tests need a headless browser: install Debian's chromium \
             (`apt-get install -y chromium chromium-driver`, as .ci/run does), point \
             CNC402_CHROMIUM at one, or set CNC402_SKIP_BROWSER_TESTS=1 to skip them"
        ),
    }
}

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-view-browser-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn view(program: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["view", program, "-o", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(&args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cnc402 view")
}

/// The blocks of the lab example are 0.34 mm long, about a pixel at the page's first zoom; a
/// click is a whole pixel (MouseEvent coordinates are integers), so the tests pick blocks
/// zoomed in (`zoom=20`), as a user would.
///
/// The page's DOM after loading `page#fragment` in the headless browser.
fn dump_dom(browser: &Path, page: &Path, fragment: &str, profile: &Path) -> String {
    let url = format!(
        "file://{}#{fragment}",
        page.canonicalize().unwrap().display()
    );
    browser_dom(browser, &url, profile, &[])
}

/// The DOM of `url` after loading it in the headless browser with `flags` besides the usual.
fn browser_dom(browser: &Path, url: &str, profile: &Path, flags: &[&str]) -> String {
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--window-size=1200,800",
            "--virtual-time-budget=10000",
            "--dump-dom",
        ])
        .args(flags)
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("start {}: {e}", browser.display()));
    // Read stdout while the browser writes it: a DOM larger than the pipe would block it.
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut dom = Vec::new();
        let _ = std::io::Read::read_to_end(&mut stdout, &mut dom);
        dom
    });
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > BROWSER_HANG_GUARD {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{} did not finish loading {url}", browser.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let dom = reader.join().unwrap();
    String::from_utf8_lossy(&dom).into_owned()
}

/// An attribute of the `#picked` element in a dumped DOM.
fn picked(dom: &str, attr: &str) -> String {
    let at = dom
        .find("id=\"picked\"")
        .unwrap_or_else(|| panic!("no #picked in the page:\n{dom}"));
    let tag_end = at + dom[at..].find('>').unwrap();
    let tag = &dom[at..tag_end];
    let key = format!("data-{attr}=\"");
    match tag.find(&key) {
        Some(k) => {
            let v = &tag[k + key.len()..];
            v[..v.find('"').unwrap()].to_string()
        }
        None => String::new(),
    }
}

/// The text of the element with `id` in a dumped DOM.
fn element_text(dom: &str, id: &str) -> String {
    let at = dom.find(&format!("id=\"{id}\"")).unwrap();
    let start = at + dom[at..].find('>').unwrap() + 1;
    dom[start..start + dom[start..].find('<').unwrap()].to_string()
}

#[test]
fn clicking_the_spike_of_the_lab_example_names_block_n1981() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = scratch("lab");
    let page = dir.join("lab.html");
    let o = view(
        "examples/lab-contour/contour.nc",
        &page,
        &["--break", "N1700", "--break", "N2200"],
    );
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // The top of the spike, and a point halfway along N1700 (ramp lap 3) in work coordinates.
    let dom = dump_dom(
        &browser,
        &page,
        "pick=-10.803,43.983,40.524",
        &dir.join("p1"),
    );
    assert_eq!(
        picked(&dom, "n"),
        "1981",
        "{}",
        element_text(&dom, "picked")
    );
    assert_eq!(picked(&dom, "file"), "examples/lab-contour/contour.nc");
    assert_eq!(picked(&dom, "line"), "1984");
    assert!(element_text(&dom, "picked").contains("N1981 G1 X-10.803 Y43.983 Z40.524"));
    let dom = dump_dom(
        &browser,
        &page,
        "pick=13.5925,-29.2830,-7.0705&zoom=20",
        &dir.join("p2"),
    );
    assert_eq!(
        picked(&dom, "n"),
        "1700",
        "{}",
        element_text(&dom, "picked")
    );
    assert!(dom.contains("N1700: examples/lab-contour/contour.nc:1703 N1700"));
    // Away from every path: nothing is named.
    let dom = dump_dom(
        &browser,
        &page,
        "view=top&pick=0,25,-7.524",
        &dir.join("p3"),
    );
    assert_eq!(picked(&dom, "n"), "", "{}", element_text(&dom, "picked"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_merged_drawing_still_names_the_exact_block() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = scratch("merged");
    let page = dir.join("merged.html");
    let o = view(
        "examples/lab-contour/contour.nc",
        &page,
        &["--max-points", "300"],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("merged within"), "{err}");
    // Midpoints of three blocks of the finishing lap, whose vertices the drawing dropped.
    for (n, p) in [
        ("2000", "-20.0895,43.2795,-7.524"),
        ("2001", "-20.5685,43.1230,-7.524"),
        ("2300", "13.5925,-29.2830,-7.524"),
    ] {
        let dom = dump_dom(&browser, &page, &format!("pick={p}&zoom=20"), &dir.join(n));
        assert_eq!(picked(&dom, "n"), n, "{}", element_text(&dom, "picked"));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_page_of_a_program_with_an_error_shows_it_and_still_picks() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = scratch("error");
    let prog = dir.join("bad.nc");
    std::fs::write(
        &prog,
        "N10 G90 G0 X0 Y0 Z5\nN20 G1 Z-1 F200\nN30 G2 X20 Y0 R10\nN40 G1 X400 Y10\nN50 M30\n",
    )
    .unwrap();
    let page = dir.join("bad.html");
    let o = view(prog.to_str().unwrap(), &page, &[]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let dom = dump_dom(&browser, &page, "view=top&pick=10,10,-1", &dir.join("p"));
    let error = element_text(&dom, "error");
    assert!(
        error.contains("bad.nc:4:8: X 400 is outside the soft limits"),
        "{error}"
    );
    // The top of the G2 arc (R10 from X0 to X20, clockwise: through X10 Y10).
    assert_eq!(picked(&dom, "n"), "30", "{}", element_text(&dom, "picked"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A page that loads the plot `p.svg` beside it in a frame, as a user's browser opens the
/// file (parsed as XML), and writes into `#out` what the browser made of it: the root
/// element, parse errors, and each section's box with every text's box, in page pixels.
const PLOT_PAGE: &str = r#"<!doctype html>
<html><body style="margin:0">
<iframe id="plot" src="p.svg" style="border:0;display:block" width="1000" height="8000"></iframe>
<pre id="out">not loaded</pre>
<script>
document.getElementById('plot').addEventListener('load', () => {
  const out = document.getElementById('out');
  try {
    const d = document.getElementById('plot').contentDocument;
    const root = d.documentElement;
    const box = e => { const b = e.getBoundingClientRect(); return [b.left, b.right, b.top, b.bottom]; };
    const r = { root: root.localName, ns: root.namespaceURI,
      errors: d.getElementsByTagName('parsererror').length, sections: [] };
    for (const g of root.children) {
      if (g.localName !== 'g') continue;
      const texts = [...g.querySelectorAll('text')].map(t => [t.textContent.trim(), box(t)]);
      r.sections.push({ id: g.id, box: box(g), texts });
    }
    out.textContent = JSON.stringify(r);
  } catch (e) { out.textContent = 'error: ' + e; }
});
</script>
</body></html>
"#;

/// `cnc402 run --plot` of two channels, opened in the browser: an SVG document without parse
/// errors, the channels' sections one under the other in channel order, and every text
/// (headings, captions, tick labels) drawn inside its section and the page's width, also the
/// heading of a channel whose program's name is longer than a line (it wraps).
#[test]
fn the_plot_of_two_channels_renders_each_section_in_its_place() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = scratch("plot");
    let main = dir.join("main.nc");
    std::fs::write(&main, "G90 G1 X10 Y5 Z-2 F600\nM30\n").unwrap();
    let long_name = format!("{}.nc", "a-long-part-program-name".repeat(6));
    let sub = dir.join(&long_name);
    std::fs::write(&sub, "G90 G1 U100 V20 F1200\nG1 W5\nM30\n").unwrap();
    let plot = dir.join("p.svg");
    let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["--config", "examples/axioma/two-channel.toml", "run"])
        .arg(&main)
        .arg(format!("--channel=1={}", sub.display()))
        .arg("--plot")
        .arg(&plot)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run cnc402");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let page = dir.join("page.html");
    std::fs::write(&page, PLOT_PAGE).unwrap();
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let flags = ["--allow-file-access-from-files"];
    let dom = browser_dom(&browser, &url, &dir.join("profile"), &flags);
    let out = element_text(&dom, "out")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    let r: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"));
    assert_eq!(r["root"], "svg");
    assert_eq!(r["ns"], "http://www.w3.org/2000/svg");
    assert_eq!(r["errors"], 0);
    let sections = r["sections"].as_array().unwrap();
    let ids: Vec<&str> = sections.iter().map(|s| s["id"].as_str().unwrap()).collect();
    assert_eq!(ids, ["channel-0", "channel-1"]);
    let b = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let mut above = 0.0;
    for s in sections {
        let sb = b(&s["box"]);
        assert!(
            sb[2] >= above - 0.5,
            "{} overlaps the section above",
            s["id"]
        );
        assert!(
            sb[3] - sb[2] > 500.0,
            "{} is {} px high",
            s["id"],
            sb[3] - sb[2]
        );
        above = sb[3];
        for t in s["texts"].as_array().unwrap() {
            let tb = b(&t[1]);
            let inside =
                tb[0] >= -0.5 && tb[1] <= 1000.5 && tb[2] >= sb[2] - 0.5 && tb[3] <= sb[3] + 0.5;
            assert!(inside, "{}: {t} outside {sb:?}", s["id"]);
        }
    }
    let texts: Vec<&str> = sections[1]["texts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t[0].as_str().unwrap())
        .collect();
    assert!(texts[0].starts_with("channel 1 (sub): /"), "{texts:?}");
    assert!(texts[..4].concat().contains(&long_name), "{texts:?}");
    assert!(texts.contains(&"toolpath UV (from above), path speed blue 0 → red 20.0 mm/s"));
    let _ = std::fs::remove_dir_all(&dir);
}
