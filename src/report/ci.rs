//! What `tmlut check` tells a CI system, in the forms CI systems read: one JSON report (numbers as
//! numbers, a summary, and JSON even when the folder could not be checked), a JUnit XML file (one
//! test case per check) and GitHub Actions workflow commands (an annotation per exceeded budget).

use serde::Serialize;

use super::check::Finding;

/// How a check run ended; the exit status follows it (0, 1, 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Every budget held.
    Passed,
    /// Some budget was exceeded (each named among the findings).
    Failed,
    /// The folder could not be checked (missing folder, unreadable manifest, bad budgets file).
    Error,
}

/// Counts of the findings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Summary {
    pub checks: usize,
    pub passed: usize,
    pub failed: usize,
}

/// The whole outcome of one `tmlut check`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CheckReport {
    pub status: Status,
    pub summary: Summary,
    /// Why the folder could not be checked (status `error` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    pub findings: Vec<Finding>,
}

impl CheckReport {
    /// The report of a folder that could be checked.
    pub fn of(findings: Vec<Finding>) -> Self {
        let failed = findings.iter().filter(|f| !f.pass).count();
        let summary = Summary { checks: findings.len(), passed: findings.len() - failed, failed };
        let status = if failed == 0 { Status::Passed } else { Status::Failed };
        CheckReport { status, summary, error: None, findings }
    }

    /// The report of a folder that could not be checked at all.
    pub fn could_not_run(error: String) -> Self {
        CheckReport {
            status: Status::Error,
            summary: Summary { checks: 0, passed: 0, failed: 0 },
            error: Some(error),
            findings: Vec::new(),
        }
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a check report is plain data") + "\n"
    }

    /// A JUnit XML document: one test suite, one test case per finding (class: the file, name:
    /// the check), a `<failure>` per exceeded budget, and one `<error>` case when the folder could
    /// not be checked, so that a CI system shows the broken job rather than an empty suite.
    pub fn to_junit(&self, folder: &str) -> String {
        let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
        let errors = usize::from(self.status == Status::Error);
        let tests = self.summary.checks + errors;
        let head = format!(
            "<testsuites name=\"tmlut check\" tests=\"{tests}\" failures=\"{}\" errors=\"{errors}\">\n  <testsuite name=\"{}\" tests=\"{tests}\" failures=\"{}\" errors=\"{errors}\">\n",
            self.summary.failed,
            xml_escape(folder),
            self.summary.failed
        );
        xml.push_str(&head);
        if let Some(error) = &self.error {
            xml.push_str(&format!(
                "    <testcase classname=\"{0}\" name=\"check\">\n      <error message=\"{1}\">{1}</error>\n    </testcase>\n",
                xml_escape(folder),
                xml_escape(error)
            ));
        }
        for finding in &self.findings {
            let (class, name) = (xml_escape(&finding.file), xml_escape(&finding.check));
            if finding.pass {
                xml.push_str(&format!("    <testcase classname=\"{class}\" name=\"{name}\">\n"));
                xml.push_str(&format!("      <system-out>{}</system-out>\n", xml_escape(&describe(finding))));
                xml.push_str("    </testcase>\n");
            } else {
                let message = xml_escape(&describe(finding));
                xml.push_str(&format!(
                    "    <testcase classname=\"{class}\" name=\"{name}\">\n      <failure message=\"{message}\">{message}</failure>\n    </testcase>\n"
                ));
            }
        }
        xml.push_str("  </testsuite>\n</testsuites>\n");
        xml
    }

    /// GitHub Actions workflow commands: an `::error` annotation per exceeded budget (titled with
    /// the file and the check) or for a folder that could not be checked, and a closing `::notice`
    /// with the counts.
    pub fn to_github(&self, folder: &str) -> String {
        let mut out = String::new();
        if let Some(error) = &self.error {
            out.push_str(&format!("::error title={}::{}\n", property("tmlut check"), data(error)));
        }
        for finding in self.findings.iter().filter(|f| !f.pass) {
            let title = format!("tmlut check: {} {}", finding.file, finding.check);
            out.push_str(&format!("::error title={}::{}\n", property(&title), data(&describe(finding))));
        }
        let counts = match self.status {
            Status::Error => "could not check the folder".to_string(),
            _ => format!("{} passed, {} failed", self.summary.passed, self.summary.failed),
        };
        out.push_str(&format!("::notice title={}::{}\n", property(&format!("tmlut check {folder}")), data(&counts)));
        out
    }
}

/// A finding in one line: what was measured against what was allowed.
fn describe(finding: &Finding) -> String {
    format!("{} is {}, budget {}", finding.check, finding.value, finding.limit)
}

/// Text as XML 1.0 character data or attribute value: the five markup characters escaped, and the
/// control characters XML 1.0 cannot hold at all replaced.
fn xml_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\t' | '\r' => out.push(' '),
            c if (c as u32) < 0x20 => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

/// The message of a workflow command: GitHub's escapes for `%`, carriage return and line feed,
/// so that a message cannot end the command early or start another.
fn data(text: &str) -> String {
    text.replace('%', "%25").replace('\r', "%0D").replace('\n', "%0A")
}

/// A property of a workflow command: as [`data`], and `:` and `,`, which end a property.
fn property(text: &str) -> String {
    data(text).replace(':', "%3A").replace(',', "%2C")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn finding(check: &str, pass: bool) -> Finding {
        Finding {
            file: "gd.dds".into(),
            check: check.into(),
            value: "2.000e-3".into(),
            limit: "<= 1.000e-3".into(),
            pass,
            measured: Some(2e-3),
            at_most: Some(1e-3),
        }
    }

    #[test]
    fn the_summary_counts_and_the_status_follow_the_findings() {
        let report = CheckReport::of(vec![finding("a", true), finding("b", false), finding("c", true)]);
        assert_eq!(report.status, Status::Failed);
        assert_eq!(report.summary, Summary { checks: 3, passed: 2, failed: 1 });
        assert_eq!(CheckReport::of(vec![finding("a", true)]).status, Status::Passed);
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
        assert_eq!(json["status"], "failed");
        assert_eq!(json["findings"][1]["measured"], 2e-3);
        assert_eq!(json["findings"][1]["at_most"], 1e-3);
    }

    #[test]
    fn junit_escapes_markup_and_counts_failures() {
        let mut hostile = finding("<script>&\"'", false);
        hostile.value = "a\u{1}b\nc".into();
        let xml = CheckReport::of(vec![finding("ok", true), hostile]).to_junit("out & <dir>");
        assert!(xml.contains("failures=\"1\""), "{xml}");
        assert!(xml.contains("name=\"&lt;script&gt;&amp;&quot;&apos;\""), "{xml}");
        assert!(xml.contains("out &amp; &lt;dir&gt;"), "{xml}");
        assert!(!xml.contains('\u{1}'), "{xml}");
        assert_eq!(xml.matches("<testcase ").count(), 2);
        assert_eq!(xml.matches("<failure ").count(), 1);
    }

    #[test]
    fn github_commands_cannot_be_ended_early_by_a_message() {
        let mut hostile = finding("x", false);
        hostile.file = "a,b:c".into();
        hostile.value = "50%\n::error::forged".into();
        let text = CheckReport::of(vec![hostile, finding("y", true)]).to_github("out");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 2, "{text}");
        assert!(lines[0].starts_with("::error title=tmlut check%3A a%2Cb%3Ac x::"), "{text}");
        assert!(lines[0].contains("50%25%0A::error::forged"), "{text}");
        assert_eq!(lines[1], "::notice title=tmlut check out::1 passed, 1 failed");
        let error = CheckReport::could_not_run("no manifest".into()).to_github("out");
        assert!(error.starts_with("::error title=tmlut check::no manifest\n"), "{error}");
    }
}
