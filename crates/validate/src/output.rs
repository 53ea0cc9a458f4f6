//! Report formats for many files at once: a human summary, JSON, JUnit XML and SARIF 2.1.0.

use std::io::{self, Write};

use serde::Serialize;

use crate::HierarchyReport;
use crate::report::{Code, Element, Finding, MeshReport, Properties, Severity};

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A human summary.
    Text,
    /// One JSON document: `{"files": [...], "passed": n, "failed": n, "unreadable": n}`.
    Json,
    /// JUnit XML: one test case per file, a failure per missing required property.
    Junit,
    /// SARIF 2.1.0: one result per finding, for code-scanning dashboards.
    Sarif,
}

/// A property that `--require` can demand.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Requirement {
    /// See [`Properties::manifold`].
    Manifold,
    /// See [`Properties::oriented`].
    Oriented,
    /// See [`Properties::closed`].
    Closed,
    /// See [`Properties::watertight`].
    Watertight,
    /// See [`Properties::clean`].
    Clean,
    /// See [`Properties::intersection_free`]; requiring it turns the check on.
    IntersectionFree,
}

impl Requirement {
    /// Every requirement.
    pub const ALL: [Self; 6] =
        [Self::Manifold, Self::Oriented, Self::Closed, Self::Watertight, Self::Clean, Self::IntersectionFree];

    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Manifold => "manifold",
            Self::Oriented => "oriented",
            Self::Closed => "closed",
            Self::Watertight => "watertight",
            Self::Clean => "clean",
            Self::IntersectionFree => "intersection-free",
        }
    }

    /// The requirement with this [`name`](Self::name).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == name)
    }

    /// Whether `p` meets it.
    pub fn holds(self, p: &Properties) -> bool {
        match self {
            Self::Manifold => p.manifold,
            Self::Oriented => p.oriented,
            Self::Closed => p.closed,
            Self::Watertight => p.watertight,
            Self::Clean => p.clean,
            Self::IntersectionFree => p.intersection_free == Some(true),
        }
    }
}

/// What validating one file gave.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Outcome {
    /// A mesh was read and checked.
    Mesh(MeshReport),
    /// A hierarchy (MRQ) was read and checked.
    Hierarchy(HierarchyReport),
    /// The file could not be read.
    Unreadable {
        /// Why.
        error: String,
    },
}

/// One file's result and verdict.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FileResult {
    /// The file as given.
    pub file: String,
    /// The required properties it lacks (empty when it passes).
    pub failed_requirements: Vec<Requirement>,
    /// The checks.
    pub outcome: Outcome,
}

impl FileResult {
    /// Judges `outcome` against `required`.
    pub fn new(file: String, outcome: Outcome, required: &[Requirement]) -> Self {
        let failed_requirements = match &outcome {
            Outcome::Mesh(r) => required.iter().copied().filter(|q| !q.holds(&r.properties)).collect(),
            Outcome::Hierarchy(h) => required.iter().copied().filter(|q| !h.all_levels(|p| q.holds(p))).collect(),
            Outcome::Unreadable { .. } => Vec::new(),
        };
        Self { file, failed_requirements, outcome }
    }

    /// Whether the file was read and meets every requirement.
    pub fn passed(&self) -> bool {
        !matches!(self.outcome, Outcome::Unreadable { .. }) && self.failed_requirements.is_empty()
    }

    /// Every finding, with the level it belongs to (`None` for a plain mesh or the links).
    fn findings(&self) -> Vec<(Option<usize>, &Finding)> {
        match &self.outcome {
            Outcome::Mesh(r) => r.findings.iter().map(|f| (None, f)).collect(),
            Outcome::Hierarchy(h) => h
                .links
                .iter()
                .map(|f| (None, f))
                .chain(h.levels.iter().enumerate().flat_map(|(k, l)| l.findings.iter().map(move |f| (Some(k), f))))
                .collect(),
            Outcome::Unreadable { .. } => Vec::new(),
        }
    }
}

/// Writes the results of many files in `format`.
pub fn write_report(w: &mut dyn Write, format: Format, files: &[FileResult]) -> io::Result<()> {
    match format {
        Format::Text => write_text(w, files),
        Format::Json => write_json(w, files),
        Format::Junit => write_junit(w, files),
        Format::Sarif => write_sarif(w, files),
    }
}

fn element_name(e: Element) -> String {
    match e {
        Element::Vertex(v) => format!("vertex {v}"),
        Element::Face(f) => format!("face {f}"),
        Element::Edge(a, b) => format!("edge {a}-{b}"),
        Element::Faces(a, b) => format!("faces {a} & {b}"),
    }
}

fn elements_line(f: &Finding) -> String {
    let shown: Vec<String> = f.elements.iter().take(8).map(|e| element_name(*e)).collect();
    let more = f.count.saturating_sub(shown.len());
    if more > 0 { format!("{}, and {more} more", shown.join(", ")) } else { shown.join(", ") }
}

fn write_text(w: &mut dyn Write, files: &[FileResult]) -> io::Result<()> {
    for r in files {
        let verdict = match (&r.outcome, r.passed()) {
            (Outcome::Unreadable { .. }, _) => "UNREADABLE",
            (_, true) => "PASS",
            (_, false) => "FAIL",
        };
        writeln!(w, "{verdict} {}", r.file)?;
        match &r.outcome {
            Outcome::Unreadable { error } => writeln!(w, "  {error}")?,
            Outcome::Mesh(m) => write_mesh_text(w, m, "  ")?,
            Outcome::Hierarchy(h) => {
                for f in &h.links {
                    writeln!(w, "  {} {}", f.code, f.message)?;
                }
                for (k, l) in h.levels.iter().enumerate() {
                    writeln!(w, "  level {k}:")?;
                    write_mesh_text(w, l, "    ")?;
                }
            }
        }
        if !r.failed_requirements.is_empty() {
            let names: Vec<_> = r.failed_requirements.iter().map(|q| q.name()).collect();
            writeln!(w, "  required but not met: {}", names.join(", "))?;
        }
    }
    let passed = files.iter().filter(|r| r.passed()).count();
    let unreadable = files.iter().filter(|r| matches!(r.outcome, Outcome::Unreadable { .. })).count();
    writeln!(
        w,
        "{} files: {passed} passed, {} failed, {unreadable} unreadable",
        files.len(),
        files.len() - passed - unreadable
    )
}

fn write_mesh_text(w: &mut dyn Write, m: &MeshReport, indent: &str) -> io::Result<()> {
    let p = &m.properties;
    let yes = |b: bool| if b { "yes" } else { "no" };
    writeln!(
        w,
        "{indent}vertices {}, faces {}, edges {}, components {}, χ = {}{}",
        m.vertices,
        m.faces,
        m.edges,
        m.components.len(),
        m.euler_characteristic,
        if m.welded_vertices > 0 { format!(" ({} vertices welded)", m.welded_vertices) } else { String::new() }
    )?;
    writeln!(
        w,
        "{indent}manifold {}, oriented {}, closed {}, watertight {}, clean {}",
        yes(p.manifold),
        yes(p.oriented),
        yes(p.closed),
        yes(p.watertight),
        yes(p.clean)
    )?;
    if let Some(free) = p.intersection_free {
        writeln!(w, "{indent}intersection-free {}", yes(free))?;
    }
    let genera: Vec<String> = m.components.iter().filter_map(|c| c.genus).map(|g| g.to_string()).collect();
    if !genera.is_empty() {
        writeln!(w, "{indent}genus of closed components: {}", genera.join(", "))?;
    }
    for f in &m.findings {
        writeln!(w, "{indent}{:<22} {} ({})", f.code.as_str(), f.message, elements_line(f))?;
    }
    Ok(())
}

#[derive(Serialize)]
struct JsonDoc<'a> {
    files: &'a [FileResult],
    passed: usize,
    failed: usize,
    unreadable: usize,
}

fn write_json(w: &mut dyn Write, files: &[FileResult]) -> io::Result<()> {
    let unreadable = files.iter().filter(|r| matches!(r.outcome, Outcome::Unreadable { .. })).count();
    let passed = files.iter().filter(|r| r.passed()).count();
    let doc = JsonDoc { files, passed, failed: files.len() - passed - unreadable, unreadable };
    serde_json::to_writer_pretty(&mut *w, &doc)?;
    writeln!(w)
}

fn xml_escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' && c != '\r' => {}
            c => o.push(c),
        }
    }
    o
}

fn write_junit(w: &mut dyn Write, files: &[FileResult]) -> io::Result<()> {
    let failures = files.iter().filter(|r| !r.passed() && !matches!(r.outcome, Outcome::Unreadable { .. })).count();
    let errors = files.iter().filter(|r| matches!(r.outcome, Outcome::Unreadable { .. })).count();
    writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        w,
        r#"<testsuites name="octowrap validate" tests="{}" failures="{failures}" errors="{errors}">"#,
        files.len()
    )?;
    writeln!(
        w,
        r#"  <testsuite name="octowrap validate" tests="{}" failures="{failures}" errors="{errors}">"#,
        files.len()
    )?;
    for r in files {
        let name = xml_escape(&r.file);
        writeln!(w, r#"    <testcase classname="octowrap.validate" name="{name}">"#)?;
        match &r.outcome {
            Outcome::Unreadable { error } => {
                writeln!(w, r#"      <error message="{}"/>"#, xml_escape(error))?;
            }
            _ if !r.failed_requirements.is_empty() => {
                let names: Vec<_> = r.failed_requirements.iter().map(|q| q.name()).collect();
                let body: Vec<String> = r
                    .findings()
                    .iter()
                    .filter(|(_, f)| f.severity == Severity::Error)
                    .map(|(lvl, f)| {
                        let at = lvl.map(|k| format!("level {k}: ")).unwrap_or_default();
                        format!("{at}{} {} ({})", f.code, f.message, elements_line(f))
                    })
                    .collect();
                writeln!(
                    w,
                    r#"      <failure message="not {}" type="octowrap.validate">{}</failure>"#,
                    xml_escape(&names.join(", not ")),
                    xml_escape(&body.join("\n"))
                )?;
            }
            _ => {}
        }
        writeln!(w, "    </testcase>")?;
    }
    writeln!(w, "  </testsuite>")?;
    writeln!(w, "</testsuites>")
}

fn write_sarif(w: &mut dyn Write, files: &[FileResult]) -> io::Result<()> {
    use serde_json::json;
    let rules: Vec<_> = Code::ALL
        .iter()
        .map(|c| {
            json!({
                "id": c.as_str(),
                "shortDescription": { "text": c.description() },
                "defaultConfiguration": { "level": sarif_level(c.severity()) },
            })
        })
        .collect();
    let mut results = Vec::new();
    for r in files {
        let location = |logical: Vec<serde_json::Value>| json!([{ "physicalLocation": { "artifactLocation": { "uri": r.file } }, "logicalLocations": logical }]);
        if let Outcome::Unreadable { error } = &r.outcome {
            results.push(json!({
                "ruleId": "E-UNREADABLE",
                "level": "error",
                "message": { "text": error },
                "locations": location(Vec::new()),
            }));
        }
        for (lvl, f) in r.findings() {
            let logical: Vec<_> = f
                .elements
                .iter()
                .map(|e| {
                    let name = element_name(*e);
                    let full = lvl.map_or_else(|| name.clone(), |k| format!("level {k}/{name}"));
                    json!({ "name": name, "fullyQualifiedName": full, "kind": "element" })
                })
                .collect();
            let at = lvl.map(|k| format!("level {k}: ")).unwrap_or_default();
            results.push(json!({
                "ruleId": f.code.as_str(),
                "ruleIndex": Code::ALL.iter().position(|c| *c == f.code),
                "level": sarif_level(f.severity),
                "message": { "text": format!("{at}{}", f.message) },
                "locations": location(logical),
                "properties": { "count": f.count },
            }));
        }
    }
    let doc = json!({
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{
            "tool": { "driver": {
                "name": "octowrap validate",
                "version": env!("CARGO_PKG_VERSION"),
                "rules": rules,
            }},
            "results": results,
        }],
    });
    serde_json::to_writer_pretty(&mut *w, &doc)?;
    writeln!(w)
}

fn sarif_level(s: Severity) -> &'static str {
    match s {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Info => "note",
    }
}
