//! Reading the row and the column of each view from file names as real exports write them.
//!
//! Pure string analysis (no file system), used by [`super::grid_folder`].
//!
//! # The rule
//!
//! 1. **Numbers.** Each name (without its extension) is split into numbers and the text around
//!    them. A number is a run of ASCII digits, optionally with decimals (`381.909271`) and a
//!    minus sign when the `-` follows the start of the name or a character that is neither a
//!    letter nor a digit (`_-381.9`; in `img-3-7` the dashes are separators). A number with a
//!    sign or decimals is a **position** (Stanford archive names carry the camera position after
//!    the indices) and never an index.
//! 2. **Naming rules.** Names that have the same text around their numbers and the same
//!    extension (`2067_#_#.png`) were written by one rule and form a group; names starting with
//!    `.` (hidden files, macOS `._` resource forks) are never views.
//! 3. **Indices.** In a group, a number that is the same in every name (a scene, frame or
//!    camera number) is not an index. The row and the column are two of the remaining whole
//!    numbers that together form a **complete grid**: their values are contiguous ranges
//!    (counting from 0, 1 or anything else, zero-padded or not) and every (row, column) pair
//!    occurs exactly once.
//! 4. **Which is which.** The earlier number in the name is the row, unless the words before the
//!    numbers say otherwise (`col_3_row_7`: a number after `row` or `r` is the row, one after
//!    `col`, `column` or `c` the column).
//! 5. **Exactly one reading.** If exactly one group and one pair of numbers form a complete
//!    grid, that is the light field; image files outside it are ignored with a warning. No
//!    reading (a missing view, a duplicate, only one number varying) and several readings (two
//!    complete grids) are errors that list what was found.

use std::collections::{BTreeMap, HashSet};

use super::GridSize;

/// Largest grid extent accepted; guards against numbers like timestamps read as indices.
pub const MAX_GRID: u64 = 10_000;

/// A number in a file name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Number {
    /// As written: sign, leading zeros and decimals included.
    pub text: String,
    /// Its value when it can be an index: no sign, no decimals, fits a u64.
    pub index: Option<u64>,
    /// Byte range in the name.
    pub start: usize,
    pub end: usize,
}

/// The numbers of `stem` in order (see the module docs for what a number is).
pub fn numbers(stem: &str) -> Vec<Number> {
    let b = stem.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let signed = b[i] == b'-'
            && b.get(i + 1).is_some_and(u8::is_ascii_digit)
            && (i == 0 || !b[i - 1].is_ascii_alphanumeric());
        if !(b[i].is_ascii_digit() || signed) {
            i += 1;
            continue;
        }
        let start = i;
        if signed {
            i += 1;
        }
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        let mut decimal = false;
        if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
            decimal = true;
            i += 1;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
        }
        // The bytes matched are ASCII, so the range lies on character boundaries.
        let text = stem[start..i].to_string();
        let index = if signed || decimal {
            None
        } else {
            text.parse().ok()
        };
        out.push(Number {
            text,
            index,
            start,
            end: i,
        });
    }
    out
}

/// `stem` with every number replaced by `#`: the naming rule shared by a group of files.
pub fn pattern(stem: &str, numbers: &[Number]) -> String {
    let mut out = String::new();
    let mut at = 0;
    for n in numbers {
        out.push_str(&stem[at..n.start]);
        out.push('#');
        at = n.end;
    }
    out.push_str(&stem[at..]);
    out
}

/// What a number of a naming rule turned out to be.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FieldRole {
    /// The grid row (t).
    Row { first: u64, last: u64 },
    /// The grid column (s).
    Column { first: u64, last: u64 },
    /// The same in every name (a scene, frame or camera number).
    Constant { text: String },
    /// Has a sign or decimals: a camera position, not an index.
    Position,
    /// Varies but is neither the row nor the column.
    Other,
}

/// How a folder's file names were read: the answer `info` reports.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GridNaming {
    /// The first view's name with the row and column shown as `{row}` and `{col}`, other
    /// varying numbers as `#` and positions as `{pos}`, e.g. `2067_{row}_{col}.png`.
    pub pattern: String,
    /// The role of each number in the names, in order (number 1 is the first).
    pub fields: Vec<FieldRole>,
    /// Number of views.
    pub files: usize,
    /// The sub-folder the views were found in, when not the light field folder itself.
    pub subfolder: Option<String>,
}

impl GridNaming {
    /// A one-line description: which numbers gave the row and the column, and which were
    /// ignored.
    pub fn describe(&self) -> String {
        let mut used = Vec::new();
        let mut ignored = Vec::new();
        for (i, f) in self.fields.iter().enumerate() {
            let n = i + 1;
            match f {
                FieldRole::Row { first, last } => {
                    used.insert(0, format!("row = number {n} ({first}–{last})"))
                }
                FieldRole::Column { first, last } => {
                    used.push(format!("column = number {n} ({first}–{last})"))
                }
                FieldRole::Constant { text } => {
                    ignored.push(format!("number {n} ({text}) is the same in every name"))
                }
                FieldRole::Position => {
                    ignored.push(format!("number {n} has a sign or decimals (a position)"))
                }
                FieldRole::Other => ignored.push(format!("number {n} varies but is not needed")),
            }
        }
        let mut s = format!("{} from names like {}", used.join(", "), self.pattern);
        if !ignored.is_empty() {
            s.push_str("; ");
            s.push_str(&ignored.join("; "));
        }
        if let Some(sub) = &self.subfolder {
            s.push_str(&format!("; views in sub-folder {sub}"));
        }
        s
    }
}

/// The reading of a folder: its grid, its naming, and the files in row-major order.
#[derive(Debug, Clone, PartialEq)]
pub struct GridReading {
    pub grid: GridSize,
    pub naming: GridNaming,
    /// Indices into the names given to [`read_grid`], row-major (`t · cols + s`).
    pub order: Vec<usize>,
    /// Indices of image names that are not part of the grid.
    pub ignored: Vec<usize>,
}

/// Why no single grid could be read.
#[derive(Debug, Clone, PartialEq)]
pub enum NamingError {
    /// No two names share a naming rule with a number in it.
    NoNumberedViews,
    /// A naming rule was found, but fewer than two of its numbers vary.
    OneIndex(String),
    /// A naming rule with two varying numbers whose pairs do not form a complete grid.
    Incomplete(String),
    /// More than one complete grid.
    Ambiguous(String),
}

impl NamingError {
    /// The explanation, without the folder.
    pub fn message(&self) -> &str {
        match self {
            NamingError::NoNumberedViews => "no two image files share a naming rule with numbers",
            NamingError::OneIndex(m) | NamingError::Incomplete(m) | NamingError::Ambiguous(m) => m,
        }
    }
}

/// One naming rule and its files.
struct Group<'a> {
    /// Indices into the names.
    files: Vec<usize>,
    numbers: Vec<&'a [Number]>,
    stems: Vec<&'a str>,
    ext: &'a str,
}

impl Group<'_> {
    fn field_count(&self) -> usize {
        self.numbers[0].len()
    }

    /// Values of number `j` when it can be an index in every name.
    fn index_values(&self, j: usize) -> Option<Vec<u64>> {
        self.numbers.iter().map(|n| n[j].index).collect()
    }

    fn is_constant(&self, j: usize) -> bool {
        // By value: `01` and `1` are the same number.
        match self.index_values(j) {
            Some(v) => v.iter().all(|&x| x == v[0]),
            None => self
                .numbers
                .iter()
                .all(|n| n[j].text == self.numbers[0][j].text),
        }
    }

    /// Numbers that vary and can be indices.
    fn varying(&self) -> Vec<usize> {
        (0..self.field_count())
            .filter(|&j| !self.is_constant(j) && self.index_values(j).is_some())
            .collect()
    }

    /// A name of the group, for messages.
    fn example(&self) -> String {
        format!("{}.{}", self.stems[0], self.ext)
    }

    /// The lower-case word just before number `j` of the first name, separators skipped.
    fn label(&self, j: usize) -> String {
        let stem = self.stems[0];
        let before = &stem[..self.numbers[0][j].start];
        let trimmed = before.trim_end_matches(|c: char| !c.is_ascii_alphanumeric());
        let word: String = trimmed
            .chars()
            .rev()
            .take_while(|c| c.is_ascii_alphabetic())
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        word.to_ascii_lowercase()
    }
}

/// How a pair of numbers covers the grid their ranges span.
struct PairFit {
    a: usize,
    b: usize,
    a_range: (u64, u64),
    b_range: (u64, u64),
    /// Distinct (a, b) pairs.
    distinct: usize,
    /// Files of the group (distinct < files means duplicates).
    files: usize,
    /// Cells of the spanned grid, `(a_max − a_min + 1)·(b_max − b_min + 1)`.
    cells: u64,
    /// First missing cell and the number missing; first duplicate (two file positions).
    missing: Option<((u64, u64), u64)>,
    duplicate: Option<(usize, usize, (u64, u64))>,
}

impl PairFit {
    /// (row number, column number, row range, column range): the earlier number is the row
    /// unless the words before the numbers say otherwise.
    fn oriented(&self, g: &Group) -> (usize, usize, (u64, u64), (u64, u64)) {
        let is_row = |w: &str| matches!(w, "row" | "r");
        let is_col = |w: &str| matches!(w, "col" | "column" | "c");
        let (la, lb) = (g.label(self.a), g.label(self.b));
        if (is_col(&la) && !is_col(&lb)) || (is_row(&lb) && !is_row(&la)) {
            (self.b, self.a, self.b_range, self.a_range)
        } else {
            (self.a, self.b, self.a_range, self.b_range)
        }
    }

    fn complete(&self) -> bool {
        self.distinct == self.files && self.cells == self.files as u64
    }

    fn fill(&self) -> f64 {
        self.distinct as f64 / self.cells.max(1) as f64
    }
}

fn fit_pair(g: &Group, a: usize, b: usize) -> Option<PairFit> {
    let va = g.index_values(a)?;
    let vb = g.index_values(b)?;
    let range = |v: &[u64]| {
        (
            v.iter().copied().min().unwrap_or(0),
            v.iter().copied().max().unwrap_or(0),
        )
    };
    let (ra, rb) = (range(&va), range(&vb));
    let (span_a, span_b) = (ra.1 - ra.0 + 1, rb.1 - rb.0 + 1);
    if span_a > MAX_GRID || span_b > MAX_GRID {
        return None;
    }
    let mut seen: BTreeMap<(u64, u64), usize> = BTreeMap::new();
    let mut duplicate = None;
    for (k, (&x, &y)) in va.iter().zip(&vb).enumerate() {
        if let Some(&first) = seen.get(&(x, y)) {
            duplicate.get_or_insert((first, k, (x, y)));
        } else {
            seen.insert((x, y), k);
        }
    }
    let cells = span_a * span_b;
    let mut missing = None;
    if (seen.len() as u64) < cells {
        let count = cells - seen.len() as u64;
        'find: for x in ra.0..=ra.1 {
            for y in rb.0..=rb.1 {
                if !seen.contains_key(&(x, y)) {
                    missing = Some(((x, y), count));
                    break 'find;
                }
            }
        }
    }
    Some(PairFit {
        a,
        b,
        a_range: ra,
        b_range: rb,
        distinct: seen.len(),
        files: va.len(),
        cells,
        missing,
        duplicate,
    })
}

/// Reads a grid from image file `names` (file names with extension, no folder). `subfolder`
/// is recorded in the naming. See the module docs for the rule.
pub fn read_grid(names: &[String], subfolder: Option<String>) -> Result<GridReading, NamingError> {
    let split: Vec<(&str, &str)> = names
        .iter()
        .map(|n| match n.rfind('.') {
            Some(dot) if dot > 0 => (&n[..dot], &n[dot + 1..]),
            _ => (n.as_str(), ""),
        })
        .collect();
    let nums: Vec<Vec<Number>> = split.iter().map(|(stem, _)| numbers(stem)).collect();
    let mut by_rule: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
    for (i, ((stem, ext), n)) in split.iter().zip(&nums).enumerate() {
        if n.is_empty() || stem.starts_with('.') {
            continue;
        }
        by_rule
            .entry((pattern(stem, n), ext.to_ascii_lowercase()))
            .or_default()
            .push(i);
    }
    let groups: Vec<Group> = by_rule
        .into_iter()
        .filter(|(_, files)| files.len() >= 2)
        .map(|(_, files)| Group {
            numbers: files.iter().map(|&i| nums[i].as_slice()).collect(),
            stems: files.iter().map(|&i| split[i].0).collect(),
            ext: split[files[0]].1,
            files,
        })
        .collect();
    if groups.is_empty() {
        return Err(NamingError::NoNumberedViews);
    }

    let mut complete: Vec<(usize, PairFit)> = Vec::new();
    for (gi, g) in groups.iter().enumerate() {
        let varying = g.varying();
        for (k, &a) in varying.iter().enumerate() {
            for &b in &varying[k + 1..] {
                if let Some(fit) = fit_pair(g, a, b).filter(PairFit::complete) {
                    complete.push((gi, fit));
                }
            }
        }
    }
    match complete.len() {
        0 => Err(explain_no_grid(&groups)),
        1 => {
            let (gi, fit) = complete.pop().expect("one reading");
            Ok(reading(&groups[gi], fit, names.len(), subfolder))
        }
        _ => {
            let list: Vec<String> = complete
                .iter()
                .map(|(gi, f)| {
                    let g = &groups[*gi];
                    format!(
                        "{} files like {}: numbers {} and {} ({}×{} views)",
                        g.files.len(),
                        g.example(),
                        f.a + 1,
                        f.b + 1,
                        f.a_range.1 - f.a_range.0 + 1,
                        f.b_range.1 - f.b_range.0 + 1
                    )
                })
                .collect();
            Err(NamingError::Ambiguous(format!(
                "the file names can be read as {} different complete grids: {}; move the views of \
                 one grid into a folder of their own",
                complete.len(),
                list.join("; ")
            )))
        }
    }
}

/// The reading of group `g` with the complete pair `fit`.
fn reading(g: &Group, fit: PairFit, total: usize, subfolder: Option<String>) -> GridReading {
    let (row, col, row_range, col_range) = fit.oriented(g);
    let grid = GridSize {
        cols: (col_range.1 - col_range.0 + 1) as usize,
        rows: (row_range.1 - row_range.0 + 1) as usize,
    };
    let rows_v = g.index_values(row).unwrap_or_default();
    let cols_v = g.index_values(col).unwrap_or_default();
    let mut order = vec![0usize; grid.len()];
    for (k, (&r, &c)) in rows_v.iter().zip(&cols_v).enumerate() {
        let s = (c - col_range.0) as usize;
        let t = (r - row_range.0) as usize;
        order[grid.index(s, t)] = g.files[k];
    }
    let fields: Vec<FieldRole> = (0..g.field_count())
        .map(|j| {
            if j == row {
                FieldRole::Row {
                    first: row_range.0,
                    last: row_range.1,
                }
            } else if j == col {
                FieldRole::Column {
                    first: col_range.0,
                    last: col_range.1,
                }
            } else if g.index_values(j).is_none() {
                FieldRole::Position
            } else if g.is_constant(j) {
                FieldRole::Constant {
                    text: g.numbers[0][j].text.clone(),
                }
            } else {
                FieldRole::Other
            }
        })
        .collect();
    // The first view's name with its roles written in.
    let stem = g.stems[0];
    let mut pattern = String::new();
    let mut at = 0;
    for (n, role) in g.numbers[0].iter().zip(&fields) {
        pattern.push_str(&stem[at..n.start]);
        match role {
            FieldRole::Row { .. } => pattern.push_str("{row}"),
            FieldRole::Column { .. } => pattern.push_str("{col}"),
            FieldRole::Constant { .. } => pattern.push_str(&n.text),
            FieldRole::Position => pattern.push_str("{pos}"),
            FieldRole::Other => pattern.push('#'),
        }
        at = n.end;
    }
    pattern.push_str(&stem[at..]);
    pattern.push('.');
    pattern.push_str(g.ext);
    let members: HashSet<usize> = g.files.iter().copied().collect();
    GridReading {
        grid,
        naming: GridNaming {
            pattern,
            fields,
            files: g.files.len(),
            subfolder,
        },
        order,
        ignored: (0..total).filter(|i| !members.contains(i)).collect(),
    }
}

/// The error for groups none of which forms a complete grid: describes the largest group and
/// its best-filled pair of numbers.
fn explain_no_grid(groups: &[Group]) -> NamingError {
    // The largest group; among equals the first in name order.
    let g = groups
        .iter()
        .max_by(|a, b| {
            a.files
                .len()
                .cmp(&b.files.len())
                .then(std::cmp::Ordering::Greater)
        })
        .expect("at least one group");
    let varying = g.varying();
    let describe_fields = || {
        (0..g.field_count())
            .map(|j| {
                let what = match g.index_values(j) {
                    None => "a position (sign or decimals)".to_string(),
                    Some(_) if g.is_constant(j) => {
                        format!("always {}", g.numbers[0][j].text)
                    }
                    Some(v) => format!(
                        "{}–{}",
                        v.iter().min().unwrap_or(&0),
                        v.iter().max().unwrap_or(&0)
                    ),
                };
                format!("number {} {what}", j + 1)
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let others = if groups.len() > 1 {
        format!(" ({} other naming rules found)", groups.len() - 1)
    } else {
        String::new()
    };
    if varying.len() < 2 {
        return NamingError::OneIndex(format!(
            "the {} image files named like {} ({}){others} have {} whole number that \
             varies, but a grid of views needs a row and a column in every name",
            g.files.len(),
            g.example(),
            describe_fields(),
            if varying.is_empty() { "no" } else { "only one" },
        ));
    }
    let mut best: Option<PairFit> = None;
    for (k, &a) in varying.iter().enumerate() {
        for &b in &varying[k + 1..] {
            if let Some(f) = fit_pair(g, a, b) {
                if best.as_ref().map_or(true, |x| f.fill() > x.fill()) {
                    best = Some(f);
                }
            }
        }
    }
    let Some(f) = best else {
        return NamingError::Incomplete(format!(
            "the {} image files named like {} ({}){others} span more than {MAX_GRID} rows or \
             columns: these numbers are not a row and a column",
            g.files.len(),
            g.example(),
            describe_fields()
        ));
    };
    let (row, col, rows, cols) = f.oriented(g);
    // (row, column) of a pair of values of numbers (a, b).
    let rc = |(x, y): (u64, u64)| if row == f.a { (x, y) } else { (y, x) };
    let mut problems = Vec::new();
    if let Some((cell, count)) = f.missing {
        let (r, c) = rc(cell);
        problems.push(format!("{count} missing, the first at row {r}, column {c}"));
    }
    if let Some((i, j, cell)) = f.duplicate {
        let (r, c) = rc(cell);
        problems.push(format!(
            "{}.{} and {}.{} are both row {r}, column {c}",
            g.stems[i], g.ext, g.stems[j], g.ext
        ));
    }
    NamingError::Incomplete(format!(
        "the {} image files named like {} ({}){others} do not form a complete grid: read as rows \
         {}–{} (number {}) × columns {}–{} (number {}) they hold {} of {} views; {}",
        g.files.len(),
        g.example(),
        describe_fields(),
        rows.0,
        rows.1,
        row + 1,
        cols.0,
        cols.1,
        col + 1,
        f.distinct,
        f.cells,
        problems.join("; ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[String]) -> Vec<String> {
        list.to_vec()
    }

    fn grid_names(
        rows: std::ops::RangeInclusive<u64>,
        cols: std::ops::RangeInclusive<u64>,
        f: impl Fn(u64, u64) -> String,
    ) -> Vec<String> {
        let mut v = Vec::new();
        for r in rows {
            for c in cols.clone() {
                v.push(f(r, c));
            }
        }
        v
    }

    #[test]
    fn numbers_keep_signs_and_decimals_apart_from_indices() {
        let n = numbers("out_03_07_-859.7_1022.8_");
        let texts: Vec<&str> = n.iter().map(|x| x.text.as_str()).collect();
        assert_eq!(texts, ["03", "07", "-859.7", "1022.8"]);
        let idx: Vec<Option<u64>> = n.iter().map(|x| x.index).collect();
        assert_eq!(idx, [Some(3), Some(7), None, None]);
        // Dashes between letters or digits are separators, not signs.
        let n = numbers("img-3-7");
        assert_eq!(
            n.iter().map(|x| x.index).collect::<Vec<_>>(),
            [Some(3), Some(7)]
        );
        assert_eq!(numbers("IMG_0001").len(), 1);
        assert!(numbers("centre").is_empty());
        // Too large for an index, still a number.
        let n = numbers("99999999999999999999999_1");
        assert_eq!(n[0].index, None);
        assert_eq!(
            pattern(
                "out_03_07_-859.7_1022.8_",
                &numbers("out_03_07_-859.7_1022.8_")
            ),
            "out_#_#_#_#_"
        );
    }

    #[test]
    fn constant_scene_numbers_are_not_indices() {
        let list = grid_names(1..=3, 1..=4, |r, c| format!("2067_{r:02}_{c:02}.png"));
        let g = read_grid(&names(&list), None).unwrap();
        assert_eq!(g.grid, GridSize { cols: 4, rows: 3 });
        assert_eq!(g.naming.pattern, "2067_{row}_{col}.png");
        assert_eq!(
            g.naming.fields[0],
            FieldRole::Constant {
                text: "2067".into()
            }
        );
        // Row-major: index t·cols + s holds row t + 1, column s + 1.
        assert_eq!(list[g.order[4 + 2]], "2067_02_03.png");
        assert!(
            g.naming.describe().contains("row = number 2 (1–3)"),
            "{}",
            g.naming.describe()
        );
    }

    #[test]
    fn labels_decide_row_and_column() {
        let list = grid_names(0..=1, 0..=2, |r, c| format!("col_{c}_row_{r}.png"));
        let g = read_grid(&names(&list), None).unwrap();
        assert_eq!(g.grid, GridSize { cols: 3, rows: 2 });
        assert_eq!(list[g.order[5]], "col_2_row_1.png");
    }

    #[test]
    fn two_complete_grids_are_ambiguous() {
        // The third number duplicates the first: (1, 2) and (2, 3) are both complete grids.
        let list = grid_names(0..=2, 0..=2, |r, c| format!("v_{r}_{c}_{r}.png"));
        let e = read_grid(&names(&list), None).unwrap_err();
        assert!(matches!(e, NamingError::Ambiguous(_)), "{e:?}");
        assert!(
            e.message().contains("2 different complete grids"),
            "{}",
            e.message()
        );
    }

    #[test]
    fn hidden_files_are_never_views() {
        let mut list = grid_names(0..=1, 0..=1, |r, c| format!("{r}_{c}.png"));
        list.extend(grid_names(0..=1, 0..=1, |r, c| format!("._{r}_{c}.png")));
        let g = read_grid(&names(&list), None).unwrap();
        assert_eq!(g.grid.len(), 4);
        assert_eq!(g.ignored.len(), 4);
    }
}
