//! A level's score: one number a run earns, computed from its metrics by a formula the level
//! states, with bronze, silver and gold thresholds. Challenges are levels with a score.
//!
//! Formula grammar (whitespace is free):
//!
//! ```text
//! formula := term (("+" | "-") term)*
//! term    := unary (("*" | "/") unary)*
//! unary   := "-" unary | atom
//! atom    := NUMBER | METRIC["." NAME] | FUNCTION "(" formula ("," formula)* ")" | "(" formula ")"
//! ```
//!
//! `METRIC` is any metric expectations may test (its `NAME` a road, destroyer, profile or
//! junction, made of letters, digits, `_`, `-` and `#`); the functions are `min(a, b, …)`,
//! `max(a, b, …)`, `abs(x)` and `clamp(x, low, high)`. Only arithmetic, so the score of a run
//! is the same on every machine.

use crate::expect::{Qualifier, metric_info};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;

/// A parsed score formula; it reads and writes as its text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Formula {
    text: String,
    root: Node,
}

/// A node of a parsed formula.
#[derive(Debug, Clone, PartialEq)]
enum Node {
    Number(f64),
    /// A measured value by its summary key (`metric` or `metric.name`).
    Key(String),
    Neg(Box<Node>),
    Binary(char, Box<Node>, Box<Node>),
    Call(Function, Vec<Node>),
}

/// The functions a formula may call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Function {
    Min,
    Max,
    Abs,
    Clamp,
}

impl Function {
    fn from_name(name: &str) -> Option<Function> {
        Some(match name {
            "min" => Function::Min,
            "max" => Function::Max,
            "abs" => Function::Abs,
            "clamp" => Function::Clamp,
            _ => return None,
        })
    }

    /// The number of arguments it takes: exactly, or at least (`true`).
    fn arity(self) -> (usize, bool) {
        match self {
            Function::Min | Function::Max => (1, true),
            Function::Abs => (1, false),
            Function::Clamp => (3, false),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Function::Min => "min",
            Function::Max => "max",
            Function::Abs => "abs",
            Function::Clamp => "clamp",
        }
    }
}

/// Why a formula could not be evaluated for a run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScoreError {
    /// A metric it reads was not measured by the run (no vehicles of a profile, no wave, …).
    #[error("`{0}` was not measured in this run")]
    NotMeasured(String),
    /// The arithmetic gave no number (a division by zero, say).
    #[error("the score is not a finite number (a division by zero?)")]
    NotFinite,
}

impl Formula {
    /// Parses a formula; an error names the character (1-based) where it went wrong and what
    /// was expected there.
    pub fn parse(text: &str) -> Result<Formula, String> {
        let mut p = Parser {
            chars: text.chars().collect(),
            i: 0,
        };
        let root = p.formula()?;
        p.skip_space();
        if p.i < p.chars.len() {
            return Err(p.error(format!(
                "expected an operator (+ - * /) or the end, found `{}`",
                p.chars[p.i]
            )));
        }
        Ok(Formula {
            text: text.trim().to_owned(),
            root,
        })
    }

    /// The formula as written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Every metric key it reads, each once, in order of appearance.
    pub fn keys(&self) -> Vec<&str> {
        fn walk<'a>(n: &'a Node, out: &mut Vec<&'a str>) {
            match n {
                Node::Number(_) => {}
                Node::Key(k) => {
                    if !out.contains(&k.as_str()) {
                        out.push(k);
                    }
                }
                Node::Neg(a) => walk(a, out),
                Node::Binary(_, a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                Node::Call(_, args) => args.iter().for_each(|a| walk(a, out)),
            }
        }
        let mut out = Vec::new();
        walk(&self.root, &mut out);
        out
    }

    /// Its value for a run's metrics (keyed as the summary keys them).
    pub fn evaluate(&self, metrics: &BTreeMap<String, f64>) -> Result<f64, ScoreError> {
        fn eval(n: &Node, m: &BTreeMap<String, f64>) -> Result<f64, ScoreError> {
            Ok(match n {
                Node::Number(v) => *v,
                Node::Key(k) => *m.get(k).ok_or_else(|| ScoreError::NotMeasured(k.clone()))?,
                Node::Neg(a) => -eval(a, m)?,
                Node::Binary(op, a, b) => {
                    let (a, b) = (eval(a, m)?, eval(b, m)?);
                    match op {
                        '+' => a + b,
                        '-' => a - b,
                        '*' => a * b,
                        _ => a / b,
                    }
                }
                Node::Call(f, args) => {
                    let values = args
                        .iter()
                        .map(|a| eval(a, m))
                        .collect::<Result<Vec<f64>, _>>()?;
                    match f {
                        Function::Min => values.iter().copied().fold(f64::INFINITY, f64::min),
                        Function::Max => values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                        Function::Abs => values[0].abs(),
                        Function::Clamp => values[0].max(values[1]).min(values[2]),
                    }
                }
            })
        }
        let v = eval(&self.root, metrics)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(ScoreError::NotFinite)
        }
    }
}

impl fmt::Display for Formula {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl TryFrom<String> for Formula {
    type Error = String;
    fn try_from(s: String) -> Result<Formula, String> {
        Formula::parse(&s)
    }
}

impl From<Formula> for String {
    fn from(f: Formula) -> String {
        f.text
    }
}

/// A recursive-descent parser over the formula's characters.
struct Parser {
    chars: Vec<char>,
    i: usize,
}

/// Deepest nesting of parentheses and unary minus a formula may use.
const MAX_DEPTH: usize = 64;

impl Parser {
    fn error(&self, message: String) -> String {
        format!("score formula, character {}: {message}", self.i + 1)
    }

    fn skip_space(&mut self) {
        while self.chars.get(self.i).is_some_and(|c| c.is_whitespace()) {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<char> {
        self.skip_space();
        self.chars.get(self.i).copied()
    }

    fn formula(&mut self) -> Result<Node, String> {
        self.formula_at(0)
    }

    fn formula_at(&mut self, depth: usize) -> Result<Node, String> {
        let mut left = self.term(depth)?;
        while let Some(op @ ('+' | '-')) = self.peek() {
            self.i += 1;
            let right = self.term(depth)?;
            left = Node::Binary(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn term(&mut self, depth: usize) -> Result<Node, String> {
        let mut left = self.unary(depth)?;
        while let Some(op @ ('*' | '/')) = self.peek() {
            self.i += 1;
            let right = self.unary(depth)?;
            left = Node::Binary(op, Box::new(left), Box::new(right));
        }
        Ok(left)
    }

    fn unary(&mut self, depth: usize) -> Result<Node, String> {
        if depth > MAX_DEPTH {
            return Err(self.error(format!("nested more than {MAX_DEPTH} deep")));
        }
        if self.peek() == Some('-') {
            self.i += 1;
            return Ok(Node::Neg(Box::new(self.unary(depth + 1)?)));
        }
        self.atom(depth)
    }

    fn atom(&mut self, depth: usize) -> Result<Node, String> {
        match self.peek() {
            None => Err(self.error(
                "the formula ends too early: expected a number, a metric or `(`".to_owned(),
            )),
            Some('(') => {
                self.i += 1;
                let inner = self.formula_at(depth + 1)?;
                self.expect_char(')')?;
                Ok(inner)
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_ascii_alphabetic() || c == '_' => self.name(depth),
            Some(c) => Err(self.error(format!("expected a number, a metric or `(`, found `{c}`"))),
        }
    }

    /// Consumes `want`, or returns the positioned error saying what was found instead.
    fn expect_char(&mut self, want: char) -> Result<(), String> {
        match self.peek() {
            Some(c) if c == want => {
                self.i += 1;
                Ok(())
            }
            Some(c) => Err(self.error(format!("expected `{want}`, found `{c}`"))),
            None => Err(self.error(format!("the formula ends too early: expected `{want}`"))),
        }
    }

    fn number(&mut self) -> Result<Node, String> {
        let start = self.i;
        while self
            .chars
            .get(self.i)
            .is_some_and(|c| c.is_ascii_digit() || *c == '.')
        {
            self.i += 1;
        }
        // An exponent: `1e3`, `2.5E-2`.
        if self
            .chars
            .get(self.i)
            .is_some_and(|c| *c == 'e' || *c == 'E')
        {
            let save = self.i;
            self.i += 1;
            if self
                .chars
                .get(self.i)
                .is_some_and(|c| *c == '+' || *c == '-')
            {
                self.i += 1;
            }
            if self.chars.get(self.i).is_some_and(char::is_ascii_digit) {
                while self.chars.get(self.i).is_some_and(char::is_ascii_digit) {
                    self.i += 1;
                }
            } else {
                self.i = save;
            }
        }
        let text: String = self.chars[start..self.i].iter().collect();
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Node::Number(v)),
            _ => {
                self.i = start;
                Err(self.error(format!("`{text}` is not a number")))
            }
        }
    }

    fn name(&mut self, depth: usize) -> Result<Node, String> {
        let start = self.i;
        let word = |c: &char| c.is_ascii_alphanumeric() || *c == '_';
        while self.chars.get(self.i).is_some_and(word) {
            self.i += 1;
        }
        let name: String = self.chars[start..self.i].iter().collect();
        if let Some(f) = Function::from_name(&name)
            && self.peek() == Some('(')
        {
            self.i += 1;
            let mut args = vec![self.formula_at(depth + 1)?];
            while self.peek() == Some(',') {
                self.i += 1;
                args.push(self.formula_at(depth + 1)?);
            }
            self.expect_char(')')?;
            let (n, at_least) = f.arity();
            if args.len() < n || (!at_least && args.len() != n) {
                self.i = start;
                let wants = if at_least {
                    format!("at least {n}")
                } else {
                    n.to_string()
                };
                return Err(self.error(format!(
                    "`{}` takes {wants} argument(s), found {}",
                    f.name(),
                    args.len()
                )));
            }
            return Ok(Node::Call(f, args));
        }
        let Some(info) = metric_info(&name) else {
            self.i = start;
            let functions = "min, max, abs, clamp";
            return Err(self.error(format!(
                "unknown metric `{name}` (the metrics are those expectations test; the functions {functions})"
            )));
        };
        let qualifier = if self.chars.get(self.i) == Some(&'.') {
            self.i += 1;
            let q_start = self.i;
            while self
                .chars
                .get(self.i)
                .is_some_and(|c| word(c) || *c == '-' || *c == '#')
            {
                self.i += 1;
            }
            if self.i == q_start {
                return Err(self.error(format!("expected a name after `{name}.`")));
            }
            Some(self.chars[q_start..self.i].iter().collect::<String>())
        } else {
            None
        };
        let needs = match info.qualifier {
            Qualifier::Road => Some("road"),
            Qualifier::Destroyer => Some("destroyer"),
            Qualifier::Junction => Some("junction"),
            Qualifier::None | Qualifier::Profile => None,
        };
        match (&qualifier, needs) {
            (None, Some(kind)) => {
                self.i = start;
                Err(self.error(format!(
                    "metric `{name}` needs a {kind}: `{name}.{}`",
                    kind.to_uppercase()
                )))
            }
            (Some(q), None) if info.qualifier == Qualifier::None => {
                self.i = start;
                Err(self.error(format!("metric `{name}` takes no `.{q}`")))
            }
            (Some(q), _) => Ok(Node::Key(format!("{name}.{q}"))),
            (None, _) => Ok(Node::Key(name)),
        }
    }
}

/// Which way a score is better.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Better {
    /// More is better (the default).
    #[default]
    Higher,
    /// Less is better (a delay, a spread).
    Lower,
}

/// A medal a score earns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Medal {
    /// The first threshold.
    Bronze,
    /// The second.
    Silver,
    /// The best.
    Gold,
}

impl Medal {
    /// Its name as the summary writes it: `bronze`, `silver`, `gold`.
    pub fn name(self) -> &'static str {
        match self {
            Medal::Bronze => "bronze",
            Medal::Silver => "silver",
            Medal::Gold => "gold",
        }
    }
}

impl fmt::Display for Medal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The score a score reaches for each medal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Medals {
    /// Bronze from this score on.
    pub bronze: f64,
    /// Silver from this score on.
    pub silver: f64,
    /// Gold from this score on.
    pub gold: f64,
}

/// A level's score: its formula, which way is better, and the medals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoreSpec {
    /// The formula over the run's metrics, e.g. `"mean_speed_kmh.human - speed_std_kmh.human"`.
    pub formula: Formula,
    /// Its unit, for people reading it (e.g. `"km/h"`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub unit: String,
    /// Which way is better.
    #[serde(default, skip_serializing_if = "is_higher")]
    pub better: Better,
    /// The thresholds of the medals (in the better direction: bronze, then silver, then gold).
    pub medals: Medals,
}

fn is_higher(b: &Better) -> bool {
    *b == Better::Higher
}

impl ScoreSpec {
    /// The medal a score earns, if any (a threshold reached counts).
    pub fn medal(&self, score: f64) -> Option<Medal> {
        let reached = |threshold: f64| match self.better {
            Better::Higher => score >= threshold,
            Better::Lower => score <= threshold,
        };
        [Medal::Gold, Medal::Silver, Medal::Bronze]
            .into_iter()
            .find(|m| reached(self.threshold(*m)))
    }

    /// The score a medal needs.
    pub fn threshold(&self, medal: Medal) -> f64 {
        match medal {
            Medal::Bronze => self.medals.bronze,
            Medal::Silver => self.medals.silver,
            Medal::Gold => self.medals.gold,
        }
    }

    /// The next medal up from `medal` (`None`: no medal yet) and the score it needs.
    pub fn next(&self, medal: Option<Medal>) -> Option<(Medal, f64)> {
        let next = match medal {
            None => Medal::Bronze,
            Some(Medal::Bronze) => Medal::Silver,
            Some(Medal::Silver) => Medal::Gold,
            Some(Medal::Gold) => return None,
        };
        Some((next, self.threshold(next)))
    }

    /// Whether the thresholds are finite and in order for the direction.
    pub fn thresholds_in_order(&self) -> bool {
        let Medals {
            bronze,
            silver,
            gold,
        } = self.medals;
        [bronze, silver, gold].iter().all(|v| v.is_finite())
            && match self.better {
                Better::Higher => bronze <= silver && silver <= gold,
                Better::Lower => bronze >= silver && silver >= gold,
            }
    }

    /// The medal a score earns and what the next one takes: `silver (gold from 8)`,
    /// `no medal (bronze from 2)`, `gold`.
    pub fn medal_text(&self, score: f64) -> String {
        let medal = self.medal(score);
        let got = medal.map_or("no medal".to_owned(), |m| m.to_string());
        match self.next(medal) {
            Some((next, at)) => format!("{got} ({next} from {at})"),
            None => got,
        }
    }

    /// A score with its unit: `7.12 km/h`.
    pub fn value_text(&self, score: f64) -> String {
        if self.unit.is_empty() {
            format!("{score:.2}")
        } else {
            format!("{score:.2} {}", self.unit)
        }
    }

    /// The score line a report prints: `12.3 km/h, silver (gold from 14)`, or why there is none.
    pub fn describe(&self, outcome: &Result<f64, ScoreError>) -> String {
        match outcome {
            Ok(score) => format!("{}, {}", self.value_text(*score), self.medal_text(*score)),
            Err(e) => format!("none: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(pairs: &[(&str, f64)]) -> BTreeMap<String, f64> {
        pairs.iter().map(|(k, v)| ((*k).to_owned(), *v)).collect()
    }

    #[test]
    fn evaluates_with_precedence_functions_and_qualifiers() {
        let m = metrics(&[
            ("mean_speed_kmh.human", 10.0),
            ("speed_std_kmh.human", 4.0),
            ("collisions", 1.0),
            ("flow_veh_per_h.end", 1800.0),
        ]);
        for (text, want) in [
            ("mean_speed_kmh.human - speed_std_kmh.human", 6.0),
            ("mean_speed_kmh.human - 2 * speed_std_kmh.human", 2.0),
            ("(mean_speed_kmh.human - 2) * 0.5", 4.0),
            ("-collisions * 5 + 1e1", 5.0),
            ("- -collisions", 1.0),
            ("flow_veh_per_h.end / 3600", 0.5),
            ("max(0, mean_speed_kmh.human - 12)", 0.0),
            ("min(3, 2, 7)", 2.0),
            ("abs(2 - speed_std_kmh.human)", 2.0),
            ("clamp(mean_speed_kmh.human, 0, 8)", 8.0),
            ("2.5E-1 * 4", 1.0),
            ("10 - 4 - 3", 3.0),
            ("12 / 3 / 2", 2.0),
        ] {
            let f = Formula::parse(text).unwrap_or_else(|e| panic!("`{text}`: {e}"));
            assert_eq!(f.evaluate(&m), Ok(want), "`{text}`");
        }
        let f = Formula::parse("mean_speed_kmh.human - collisions").expect("parses");
        assert_eq!(f.keys(), vec!["mean_speed_kmh.human", "collisions"]);
    }

    #[test]
    fn missing_metrics_and_bad_arithmetic_give_no_score() {
        let f = Formula::parse("wave_speed_kmh + 1").expect("parses");
        assert_eq!(
            f.evaluate(&BTreeMap::new()),
            Err(ScoreError::NotMeasured("wave_speed_kmh".into()))
        );
        let f = Formula::parse("1 / collisions").expect("parses");
        assert_eq!(
            f.evaluate(&metrics(&[("collisions", 0.0)])),
            Err(ScoreError::NotFinite)
        );
    }

    #[test]
    fn rejects_nonsense_with_the_place_and_what_was_expected() {
        for (text, needle) in [
            ("", "character 1: the formula ends too early"),
            ("speed + 1", "character 1: unknown metric `speed`"),
            ("collisions +", "character 13: the formula ends too early"),
            (
                "collisions ++ 2",
                "character 13: expected a number, a metric",
            ),
            ("(collisions", "expected `)`"),
            ("collisions 2", "character 12: expected an operator"),
            ("flow_veh_per_h * 2", "needs a destroyer"),
            ("collisions.main", "takes no `.main`"),
            ("mean_speed_kmh.", "expected a name after"),
            ("clamp(1, 2)", "`clamp` takes 3 argument(s), found 2"),
            ("abs()", "expected a number"),
            ("1.2.3", "`1.2.3` is not a number"),
            ("collisions $ 2", "found `$`"),
        ] {
            let err = Formula::parse(text).expect_err(text);
            assert!(err.contains(needle), "`{text}`: {err}");
        }
        let deep = format!("{}1{}", "(".repeat(200), ")".repeat(200));
        assert!(
            Formula::parse(&deep)
                .expect_err("too deep")
                .contains("nested")
        );
        let minus = format!("{}1", "-".repeat(200));
        assert!(Formula::parse(&minus).is_err());
    }

    #[test]
    fn round_trips_through_its_text() {
        let f = Formula::parse("  mean_speed_kmh.human - 2*speed_std_kmh.human ").expect("parses");
        assert_eq!(f.text(), "mean_speed_kmh.human - 2*speed_std_kmh.human");
        let back = Formula::parse(&String::from(f.clone())).expect("reparses");
        assert_eq!(back, f);
    }

    #[test]
    fn medals_follow_the_direction_and_thresholds_count() {
        let mut spec = ScoreSpec {
            formula: Formula::parse("collisions").expect("parses"),
            unit: "km/h".into(),
            better: Better::Higher,
            medals: Medals {
                bronze: 1.0,
                silver: 2.0,
                gold: 3.0,
            },
        };
        assert!(spec.thresholds_in_order());
        assert_eq!(spec.medal(0.9), None);
        assert_eq!(spec.medal(1.0), Some(Medal::Bronze));
        assert_eq!(spec.medal(2.5), Some(Medal::Silver));
        assert_eq!(spec.medal(3.0), Some(Medal::Gold));
        assert_eq!(spec.describe(&Ok(2.5)), "2.50 km/h, silver (gold from 3)");
        assert_eq!(spec.describe(&Ok(4.0)), "4.00 km/h, gold");
        assert_eq!(
            spec.describe(&Ok(0.0)),
            "0.00 km/h, no medal (bronze from 1)"
        );
        spec.better = Better::Lower;
        assert!(!spec.thresholds_in_order());
        spec.medals = Medals {
            bronze: 3.0,
            silver: 2.0,
            gold: 1.0,
        };
        assert!(spec.thresholds_in_order());
        assert_eq!(spec.medal(3.5), None);
        assert_eq!(spec.medal(2.0), Some(Medal::Silver));
        assert_eq!(spec.medal(0.5), Some(Medal::Gold));
    }
}
