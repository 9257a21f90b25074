//! What the user types during a bring-up: from the terminal, or from a file
//! (`--answers FILE`, one answer a line, read only when a question is asked). The file
//! carries the user's words only (a multimeter reading, `done`, `yes`), never what the
//! robot should find: that comes from the robot's own signals.

use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

use super::BringupError;

/// Where answers come from.
pub struct Answers {
    lines: Box<dyn BufRead>,
    /// The file's name, for errors (`None`: the terminal).
    source: Option<String>,
    /// Lines read so far.
    line: usize,
}

impl Answers {
    /// Answers typed at the terminal.
    pub fn terminal() -> Self {
        Self {
            lines: Box::new(BufReader::new(std::io::stdin())),
            source: None,
            line: 0,
        }
    }

    /// Answers read from `path`, a line at a time as questions come (a pipe or
    /// `/dev/stdin` works too).
    pub fn file(path: &Path) -> Result<Self, BringupError> {
        let file = File::open(path)
            .map_err(|e| BringupError::Answers(format!("cannot open {}: {e}", path.display())))?;
        Ok(Self {
            lines: Box::new(BufReader::new(file)),
            source: Some(path.display().to_string()),
            line: 0,
        })
    }

    /// Prints `question` on `out` as a line starting `> ` and returns the next answer,
    /// trimmed (blank lines and lines starting `#` in a file are skipped).
    pub fn ask(&mut self, out: &mut dyn Write, question: &str) -> Result<String, BringupError> {
        writeln!(out, "> {question}")?;
        out.flush()?;
        loop {
            let mut text = String::new();
            let read = self.lines.read_line(&mut text)?;
            self.line += 1;
            if read == 0 {
                return Err(BringupError::Answers(match &self.source {
                    Some(file) => format!("{file} has no answer for: {question}"),
                    None => format!("no answer for: {question}"),
                }));
            }
            let answer = text.trim();
            if self.source.is_some() && (answer.is_empty() || answer.starts_with('#')) {
                continue;
            }
            if self.source.is_some() {
                writeln!(out, "{answer}")?;
            }
            return Ok(answer.to_string());
        }
    }

    /// Asks until the answer is `done` (any case).
    pub fn until_done(&mut self, out: &mut dyn Write, question: &str) -> Result<(), BringupError> {
        loop {
            let answer = self.ask(out, &format!("{question}, then type done"))?;
            if answer.eq_ignore_ascii_case("done") {
                return Ok(());
            }
            self.not_understood(&answer)?;
        }
    }

    /// Asks a yes/no question.
    pub fn yes_no(&mut self, out: &mut dyn Write, question: &str) -> Result<bool, BringupError> {
        loop {
            let answer = self.ask(out, &format!("{question} [yes/no]"))?;
            match answer.to_ascii_lowercase().as_str() {
                "y" | "yes" => return Ok(true),
                "n" | "no" => return Ok(false),
                _ => self.not_understood(&answer)?,
            }
        }
    }

    /// Asks for a number (the first word of the answer; a unit after it is allowed).
    pub fn number(&mut self, out: &mut dyn Write, question: &str) -> Result<f64, BringupError> {
        loop {
            let answer = self.ask(out, question)?;
            let first = answer.split_whitespace().next().unwrap_or_default();
            match first.trim_end_matches('V').parse::<f64>() {
                Ok(v) if v.is_finite() => return Ok(v),
                _ => self.not_understood(&answer)?,
            }
        }
    }

    /// An answer that is not what was asked: from a file, an error naming its line; at
    /// the terminal, the question comes again.
    fn not_understood(&self, answer: &str) -> Result<(), BringupError> {
        match &self.source {
            Some(file) => Err(BringupError::Answers(format!(
                "{file}:{}: {answer:?} does not answer the question",
                self.line
            ))),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn from(text: &'static str) -> Answers {
        Answers {
            lines: Box::new(text.as_bytes()),
            source: Some("answers.txt".into()),
            line: 0,
        }
    }

    #[test]
    fn answers_come_in_order_skipping_comments() {
        let mut a = from("# the multimeter\n7.41 V\n\ndone\nyes\n");
        let mut out = Vec::new();
        assert_eq!(a.number(&mut out, "supply?").ok(), Some(7.41));
        assert!(a.until_done(&mut out, "turn it").is_ok());
        assert_eq!(a.yes_no(&mut out, "ok?").ok(), Some(true));
        let printed = String::from_utf8(out).expect("utf-8");
        assert!(printed.starts_with("> supply?\n7.41 V\n> turn it, then type done\n"));
        assert!(matches!(
            a.ask(&mut Vec::new(), "more?"),
            Err(BringupError::Answers(_))
        ));
    }

    #[test]
    fn a_wrong_answer_in_a_file_names_its_line() {
        let mut a = from("seven\n");
        match a.number(&mut Vec::new(), "supply?") {
            Err(BringupError::Answers(text)) => assert!(text.contains("answers.txt:1"), "{text}"),
            other => panic!("{other:?}"),
        }
    }
}
