//! `report.html`: a report as one self-contained page (a validation's, a real-scans run's), to open in a browser, mail
//! or attach to a CI run.
//!
//! The page is `report.md` rendered to HTML (CommonMark with tables, by `pulldown-cmark`), with a
//! table of contents, every image the report shows (the figures in `plots/`) embedded as a
//! `data:` URI, and *world steppers*: error images one at a time (a validation's saved worlds per
//! seed, `seed-S/maps/E_iii.png`, from `validation::saved_worlds`; a real log's passes), with a slider,
//! previous / next buttons and the arrow keys, and each world's scores. Links to other files of
//! the folder (the PNG figures, the maps) stay relative: they resolve beside the folder. A
//! sweep's page (`OUT/report.html`) holds the comparison and every preset's report.
//!
//! No network, no external script or style: the page is the same file on every machine. The
//! same inputs give byte-identical pages.

use crate::results::ResultsError;
use base64::Engine as _;
use mapkeeper_grid::StagedDir;
use pulldown_cmark::{CowStr, Event, HeadingLevel, Options, Parser, Tag, TagEnd};
use std::fmt::Write as _;
use std::path::Path;

/// One frame of a world stepper: a saved world's error image and its scores.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// i in W_i (a pass of a log: its k).
    pub world: usize,
    /// The caption: the world and M_i/G_i's scores.
    pub caption: String,
    /// The image, relative to the report's folder.
    pub image: String,
}

/// Error images stepped through on the page (a validation's saved worlds of one seed, a log's passes).
#[derive(Clone, Debug, PartialEq)]
pub struct WorldStepper {
    /// Its element id, unique within its part (the validation's: `worlds-seed-S`).
    pub id: String,
    /// Its heading (the validation's: `Seed S`).
    pub title: String,
    /// The frames, in world order.
    pub frames: Vec<Frame>,
}

/// One part of a page: a report's Markdown, where its relative links point (`""` for the page's
/// own folder, `"paper/"` for a preset's folder in a sweep) and its world steppers.
#[derive(Clone, Debug)]
pub struct Part<'a> {
    /// Prefix of the part's element ids (unique on the page).
    pub id: String,
    /// The report's Markdown.
    pub markdown: &'a str,
    /// The folder the Markdown's relative links are relative to, relative to the page, ending
    /// in `/` (or empty).
    pub base: String,
    /// The world steppers shown after the report.
    pub steppers: Vec<WorldStepper>,
    /// The heading over the steppers and what their images show.
    pub steppers_intro: SteppersIntro,
}

/// The heading over a part's steppers and the sentence saying what their images show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SteppersIntro {
    /// The heading.
    pub heading: &'static str,
    /// The sentence.
    pub text: &'static str,
}

impl SteppersIntro {
    /// A validation's: the saved worlds.
    pub const SAVED_WORLDS: SteppersIntro = SteppersIntro {
        heading: "The saved worlds, step by step",
        text: "The errors of each saved world's map against its ground truth: red wrongly free, orange wrongly \
occupied, blue missing; black, white and grey are right. Slider, buttons or the arrow keys step through the worlds.",
    };
}

/// Writes `report.html` of a validation folder from its `report.md` text and steppers, reading
/// the images from the folder.
pub fn write_report_html(
    dir: &StagedDir,
    title: &str,
    report_md: &str,
    steppers: &[WorldStepper],
    steppers_intro: SteppersIntro,
) -> Result<(), ResultsError> {
    let part = Part {
        id: String::new(),
        markdown: report_md,
        base: String::new(),
        steppers: steppers.to_vec(),
        steppers_intro,
    };
    let page = page_html(title, &[part], dir.path())?;
    dir.write("report.html", page.as_bytes())?;
    Ok(())
}

/// The page of `parts`, reading images relative to `root`. An image the Markdown shows that is
/// missing from the folder is an error naming it.
pub fn page_html(title: &str, parts: &[Part<'_>], root: &Path) -> Result<String, ResultsError> {
    let mut toc = String::new();
    let mut body = String::new();
    for part in parts {
        let (html, headings) = markdown_html(part, root)?;
        for (level, id, text) in headings {
            if level <= 2 {
                let _ = writeln!(toc, "<li class=\"h{level}\"><a href=\"#{id}\">{}</a></li>", escape(&text));
            }
        }
        body.push_str(&html);
        if !part.steppers.is_empty() {
            let id = format!("{}saved-worlds-stepper", part.id);
            let intro = part.steppers_intro;
            let _ = writeln!(toc, "<li class=\"h2\"><a href=\"#{id}\">{}</a></li>", escape(intro.heading));
            let _ = writeln!(body, "<h2 id=\"{id}\">{}</h2>", escape(intro.heading));
            let _ = writeln!(body, "<p>{}</p>", escape(intro.text));
            for s in &part.steppers {
                body.push_str(&stepper_html(&part.id, &part.base, s, root)?);
            }
        }
    }
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"generator\" content=\"{tool}\">\n\
<title>{title}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<nav id=\"contents\">\n<h2>Contents</h2>\n<ul>\n{toc}</ul>\n</nav>\n\
<main>\n{body}</main>\n<script>\n{SCRIPT}</script>\n</body>\n</html>\n",
        tool = escape(&format!("mapkeeper {}", env!("CARGO_PKG_VERSION"))),
        title = escape(title),
    ))
}

/// Whether a link or image target is a file of the folder (not a URL, an anchor or absolute).
fn is_relative_file(url: &str) -> bool {
    !(url.is_empty() || url.starts_with('#') || url.starts_with('/') || url.contains("://") || url.starts_with("data:"))
}

fn mime(path: &str) -> &'static str {
    match Path::new(path).extension().and_then(|e| e.to_str()) {
        Some("svg") => "image/svg+xml",
        Some("png") => "image/png",
        _ => "application/octet-stream",
    }
}

/// The `data:` URI of the image `rel` (relative to `root`).
fn data_uri(root: &Path, rel: &str) -> Result<String, ResultsError> {
    let path = root.join(rel);
    let bytes = std::fs::read(&path).map_err(ResultsError::io(&path))?;
    Ok(format!("data:{};base64,{}", mime(rel), base64::engine::general_purpose::STANDARD.encode(bytes)))
}

/// A heading's id: the part's prefix and the heading's words, lower case, joined by `-`
/// (numbered when the same text comes twice).
fn slug(prefix: &str, text: &str, taken: &mut Vec<String>) -> String {
    let words: Vec<String> =
        text.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).map(str::to_lowercase).collect();
    let base = format!("{prefix}{}", if words.is_empty() { "section".to_string() } else { words.join("-") });
    let mut id = base.clone();
    let mut k = 2;
    while taken.contains(&id) {
        id = format!("{base}-{k}");
        k += 1;
    }
    taken.push(id.clone());
    id
}

/// A heading: level, id, text.
type Heading = (usize, String, String);

/// The part's Markdown as HTML: headings given ids, images embedded, relative links rebased.
fn markdown_html(part: &Part<'_>, root: &Path) -> Result<(String, Vec<Heading>), ResultsError> {
    let mut events: Vec<Event<'_>> = Parser::new_ext(part.markdown, Options::ENABLE_TABLES).collect();
    let mut headings = Vec::new();
    let mut taken = Vec::new();
    for k in 0..events.len() {
        match &events[k] {
            Event::Start(Tag::Heading { level, .. }) => {
                let level = *level;
                let text: String = events[k + 1..]
                    .iter()
                    .take_while(|e| !matches!(e, Event::End(TagEnd::Heading(_))))
                    .filter_map(|e| match e {
                        Event::Text(t) | Event::Code(t) => Some(t.as_ref()),
                        _ => None,
                    })
                    .collect();
                let id = slug(&part.id, &text, &mut taken);
                headings.push((heading_number(level), id.clone(), text));
                events[k] =
                    Event::Start(Tag::Heading { level, id: Some(CowStr::from(id)), classes: vec![], attrs: vec![] });
            }
            Event::Start(Tag::Image { link_type, dest_url, title, id }) if is_relative_file(dest_url) => {
                let rel = format!("{}{dest_url}", part.base);
                let uri = data_uri(root, &rel)?;
                events[k] = Event::Start(Tag::Image {
                    link_type: *link_type,
                    dest_url: CowStr::from(uri),
                    title: title.clone(),
                    id: id.clone(),
                });
            }
            Event::Start(Tag::Link { link_type, dest_url, title, id }) if is_relative_file(dest_url) => {
                let rebased = format!("{}{dest_url}", part.base);
                events[k] = Event::Start(Tag::Link {
                    link_type: *link_type,
                    dest_url: CowStr::from(rebased),
                    title: title.clone(),
                    id: id.clone(),
                });
            }
            _ => {}
        }
    }
    let mut html = String::new();
    pulldown_cmark::html::push_html(&mut html, events.into_iter());
    Ok((html, headings))
}

fn heading_number(level: HeadingLevel) -> usize {
    match level {
        HeadingLevel::H1 => 1,
        HeadingLevel::H2 => 2,
        HeadingLevel::H3 => 3,
        HeadingLevel::H4 => 4,
        HeadingLevel::H5 => 5,
        HeadingLevel::H6 => 6,
    }
}

/// One stepper: every frame's image embedded, the first shown.
fn stepper_html(prefix: &str, base: &str, s: &WorldStepper, root: &Path) -> Result<String, ResultsError> {
    let id = format!("{prefix}{}", s.id);
    let n = s.frames.len();
    let mut h = format!(
        "<section class=\"stepper\" id=\"{id}\">\n<h3>{title}</h3>\n<div class=\"controls\">\
<button type=\"button\" data-step=\"-1\" aria-label=\"previous world\">&#9664;</button> \
<input type=\"range\" min=\"0\" max=\"{max}\" value=\"0\" step=\"1\" aria-label=\"world\"> \
<button type=\"button\" data-step=\"1\" aria-label=\"next world\">&#9654;</button> \
<span class=\"label\">{first}</span> <span class=\"count\">({n} worlds)</span></div>\n",
        title = escape(&s.title),
        max = n - 1,
        first = escape(&s.frames[0].caption),
    );
    for (k, f) in s.frames.iter().enumerate() {
        let uri = data_uri(root, &format!("{base}{}", f.image))?;
        let _ = writeln!(
            h,
            "<figure data-world=\"{w}\" data-caption=\"{c}\"{hidden}><img src=\"{uri}\" alt=\"errors of W_{w}, {title}\">\
<figcaption>{c} &middot; <a href=\"{base}{img}\">PNG</a></figcaption></figure>",
            w = f.world,
            c = escape(&f.caption),
            hidden = if k == 0 { "" } else { " hidden" },
            title = escape(&s.title.to_lowercase()),
            img = escape(&f.image),
        );
    }
    h.push_str("</section>\n");
    Ok(h)
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

const STYLE: &str = "body { font-family: system-ui, sans-serif; margin: 0; display: flex; }
nav#contents { width: 16rem; flex: none; padding: 1rem; border-right: 1px solid #ccc; height: 100vh; \
position: sticky; top: 0; overflow-y: auto; font-size: 0.85rem; box-sizing: border-box; }
nav#contents ul { list-style: none; padding-left: 0; }
nav#contents li.h2 { padding-left: 1rem; }
main { padding: 1rem 2rem; max-width: 90rem; min-width: 0; }
table { border-collapse: collapse; margin: 0.5rem 0 1rem; font-size: 0.85rem; display: block; overflow-x: auto; }
th, td { border: 1px solid #bbb; padding: 0.2rem 0.5rem; text-align: left; }
th { background: #eee; }
img { max-width: 100%; }
.stepper img { image-rendering: pixelated; border: 1px solid #999; width: min(100%, 60rem); }
.stepper .controls { margin: 0.5rem 0; }
.stepper input[type=range] { width: 20rem; vertical-align: middle; }
code { background: #f4f4f4; padding: 0 0.2rem; }
";

const SCRIPT: &str = "for (const s of document.querySelectorAll('section.stepper')) {
  const frames = s.querySelectorAll('figure');
  const range = s.querySelector('input[type=range]');
  const label = s.querySelector('.label');
  const show = (k) => {
    k = Math.max(0, Math.min(frames.length - 1, k));
    frames.forEach((f, j) => { f.hidden = j !== k; });
    range.value = k;
    label.textContent = frames[k].dataset.caption;
  };
  range.addEventListener('input', () => show(Number(range.value)));
  for (const b of s.querySelectorAll('button[data-step]')) {
    b.addEventListener('click', () => show(Number(range.value) + Number(b.dataset.step)));
  }
  s.tabIndex = 0;
  s.addEventListener('keydown', (e) => {
    if (e.key === 'ArrowLeft') { show(Number(range.value) - 1); e.preventDefault(); }
    if (e.key === 'ArrowRight') { show(Number(range.value) + 1); e.preventDefault(); }
  });
}
";
