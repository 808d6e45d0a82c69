//! The book in `docs/` and the README read as documentation, checked against the repository and the
//! built `pbd` binary:
//!
//! - every relative Markdown link in `README.md` and `docs/src/**/*.md` resolves to an existing file
//!   inside the repository, and a `#fragment` into a Markdown file names one of its headings (GitHub /
//!   mdBook slugs: lowercase, spaces to `-`, punctuation other than `-` and `_` dropped, repeats `-1`,
//!   `-2`, …);
//! - every chapter `docs/src/SUMMARY.md` lists exists, and every `.md` under `docs/src` is listed;
//! - every command line in a fenced code block (untyped, `sh`, `bash`, `shell` or `console`) that runs
//!   `pbd …` (after an optional `$ ` prompt; also `cargo run … -p pbd-cli -- …`) names a real subcommand
//!   path — `pbd WORDS --help` exits 0, WORDS being the tokens before the first one that starts with `-`
//!   or contains `/`, `.` or `<` — and every long flag on it appears in that `--help` text; the
//!   synopses in ```text blocks (`pbd record [--scene S] …`) likewise, their path ending at a
//!   placeholder (`FILE`) or a bracket and every `--flag` on the line checked; and so are the inline
//!   code spans of the prose that start with `pbd ` (`pbd grasp eval --seed 0`).
//!
//! Every problem is collected and reported in one failure naming file and line. Building the book
//! with mdBook stays optional; this test needs only the files and the binary. Std only.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};
use std::process::Command;

/// The repository root.
fn repo() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    root.canonicalize().expect("the repository root exists")
}

/// `path` relative to the repository root, for messages.
fn rel(root: &Path, path: &Path) -> String {
    path.strip_prefix(root).unwrap_or(path).display().to_string()
}

/// Every `.md` file under `dir`, sorted.
fn markdown_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = std::fs::read_dir(&d).unwrap_or_else(|e| panic!("reading {}: {e}", d.display()));
        for entry in entries {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "md") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

// ---------------------------------------------------------------------------------------------
// Markdown, by hand: fenced blocks, code spans, links, headings.

/// A fenced code block: its info string (`sh`, `bash`, …; empty when untyped) and its lines with
/// their 1-based line numbers.
#[derive(Debug)]
struct Fence {
    info: String,
    lines: Vec<(usize, String)>,
}

/// A Markdown file split into prose (fenced blocks blanked out, line numbers kept) and its fences.
#[derive(Debug)]
struct Parsed {
    prose: Vec<String>,
    fences: Vec<Fence>,
}

/// The fence marker a line opens or closes with (``` or ~~~, three or more, after up to any
/// indentation: fences inside list items are indented), and the rest of the line.
fn fence_marker(line: &str) -> Option<(char, usize, &str)> {
    let t = line.trim_start();
    let c = t.chars().next()?;
    if c != '`' && c != '~' {
        return None;
    }
    let n = t.chars().take_while(|&x| x == c).count();
    (n >= 3).then(|| (c, n, &t[n..]))
}

fn parse(text: &str) -> Parsed {
    let mut prose = Vec::new();
    let mut fences = Vec::new();
    let mut open: Option<(char, usize, Fence)> = None;
    for (i, line) in text.lines().enumerate() {
        let number = i + 1;
        match (&mut open, fence_marker(line)) {
            (None, Some((c, n, rest))) => {
                let info = rest
                    .trim()
                    .split(|x: char| x.is_whitespace() || x == ',')
                    .next()
                    .unwrap_or("");
                open = Some((
                    c,
                    n,
                    Fence {
                        info: info.to_lowercase(),
                        lines: Vec::new(),
                    },
                ));
                prose.push(String::new());
            }
            (Some((c, n, _)), Some((c2, n2, rest))) if *c == c2 && n2 >= *n && rest.trim().is_empty() => {
                fences.push(open.take().expect("an open fence").2);
                prose.push(String::new());
            }
            (Some((_, _, fence)), _) => {
                fence.lines.push((number, line.to_string()));
                prose.push(String::new());
            }
            (None, None) => prose.push(line.to_string()),
        }
    }
    if let Some((_, _, fence)) = open {
        fences.push(fence);
    }
    Parsed { prose, fences }
}

/// The prose with the contents of inline code spans replaced by spaces (a span may cross line breaks,
/// not a blank line; a run of N backticks closes at the next run of exactly N), line structure kept;
/// and the spans themselves with the line each starts on.
fn split_code_spans(prose: &[String]) -> (Vec<String>, Vec<(usize, String)>) {
    let text: Vec<char> = prose.join("\n").chars().collect();
    let mut out = text.clone();
    let mut spans = Vec::new();
    let run_at = |i: usize| text[i..].iter().take_while(|&&c| c == '`').count();
    let mut i = 0;
    while i < text.len() {
        if text[i] != '`' {
            i += 1;
            continue;
        }
        let n = run_at(i);
        let mut j = i + n;
        let mut close = None;
        while j < text.len() {
            if text[j] == '\n'
                && text[j + 1..]
                    .iter()
                    .take_while(|&&c| c != '\n')
                    .all(|c| c.is_whitespace())
            {
                break; // a code span ends with its paragraph
            }
            if text[j] == '`' {
                let m = run_at(j);
                if m == n {
                    close = Some(j);
                    break;
                }
                j += m;
            } else {
                j += 1;
            }
        }
        match close {
            Some(j) => {
                let line = 1 + text[..i].iter().filter(|&&c| c == '\n').count();
                let content: String = text[i + n..j]
                    .iter()
                    .map(|&c| if c == '\n' { ' ' } else { c })
                    .collect();
                spans.push((line, content.trim().to_string()));
                for c in &mut out[i..j + n] {
                    if *c != '\n' {
                        *c = ' ';
                    }
                }
                i = j + n;
            }
            None => i += n,
        }
    }
    let blanked = out
        .into_iter()
        .collect::<String>()
        .split('\n')
        .map(str::to_string)
        .collect();
    (blanked, spans)
}

fn without_code_spans(prose: &[String]) -> Vec<String> {
    split_code_spans(prose).0
}

/// The links `[text](target)` (and images) of a prose line: the targets, without a title.
fn link_targets(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(k) = rest.find("](") {
        let after = &rest[k + 2..];
        let mut depth = 0usize;
        let mut end = None;
        for (i, c) in after.char_indices() {
            match c {
                '(' => depth += 1,
                ')' if depth == 0 => {
                    end = Some(i);
                    break;
                }
                ')' => depth -= 1,
                _ => {}
            }
        }
        let Some(end) = end else { break };
        let mut target = after[..end].trim();
        if let Some(t) = target.strip_prefix('<').and_then(|t| t.split_once('>')) {
            target = t.0;
        } else if let Some((t, _title)) = target.split_once(char::is_whitespace) {
            target = t;
        }
        out.push(target.to_string());
        rest = &after[end..];
    }
    out
}

/// The anchor a heading gets on GitHub and in mdBook: links reduced to their text, lowercase,
/// whitespace to `-`, every character other than letters, digits, `-` and `_` dropped.
fn slug(heading: &str) -> String {
    // `[text](url)` → `text`
    let mut text = String::new();
    let mut rest = heading;
    while let Some(k) = rest.find("](") {
        let (before, after) = rest.split_at(k);
        text.push_str(before);
        match after.find(')') {
            Some(e) => rest = &after[e + 1..],
            None => {
                rest = after;
                break;
            }
        }
    }
    text.push_str(rest);
    text.trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            c if c.is_whitespace() => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a Markdown text's headings (ATX `#` headings outside fences), with GitHub's
/// `-1`, `-2` suffixes for repeats.
fn anchors(text: &str) -> BTreeSet<String> {
    let parsed = parse(text);
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeSet::new();
    for line in &parsed.prose {
        let t = line.trim_start();
        let hashes = t.chars().take_while(|&c| c == '#').count();
        if !(1..=6).contains(&hashes) || !t[hashes..].starts_with([' ', '\t']) {
            continue;
        }
        let title = t[hashes..].trim().trim_end_matches('#').trim();
        let base = slug(title);
        let count = seen.entry(base.clone()).or_insert(0);
        out.insert(if *count == 0 {
            base.clone()
        } else {
            format!("{base}-{count}")
        });
        *count += 1;
    }
    out
}

/// Whether a link target is an address outside the repository (a scheme, or `//host`).
fn is_external(target: &str) -> bool {
    if target.starts_with("//") {
        return true;
    }
    match target.split_once(':') {
        Some((scheme, _)) => {
            !scheme.is_empty()
                && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
                && !scheme.contains('/')
        }
        None => false,
    }
}

/// `path` with `.` and `..` resolved lexically (no symlinks followed), or None when `..` climbs above
/// the root of the path.
fn normalize(path: &Path) -> Option<PathBuf> {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    return None;
                }
            }
            other => out.push(other),
        }
    }
    Some(out)
}

#[derive(Debug, Default)]
struct Tally {
    links: usize,
    anchors: usize,
    external: usize,
    commands: usize,
    synopses: usize,
    spans: usize,
    flags: usize,
}

/// Checks the relative links of one Markdown file.
fn check_links(root: &Path, file: &Path, text: &str, tally: &mut Tally, failures: &mut Vec<String>) {
    let parsed = parse(text);
    let dir = file.parent().expect("a file has a directory");
    let mut anchor_cache: BTreeMap<PathBuf, BTreeSet<String>> = BTreeMap::new();
    for (i, line) in without_code_spans(&parsed.prose).iter().enumerate() {
        let at = format!("{}:{}", rel(root, file), i + 1);
        for target in link_targets(line) {
            if target.is_empty() {
                failures.push(format!("{at}: empty link target"));
                continue;
            }
            if is_external(&target) {
                tally.external += 1;
                continue;
            }
            tally.links += 1;
            let (path_part, fragment) = match target.split_once('#') {
                Some((p, f)) => (p, Some(f)),
                None => (target.as_str(), None),
            };
            let dest = if path_part.is_empty() {
                file.to_path_buf()
            } else if let Some(from_root) = path_part.strip_prefix('/') {
                root.join(from_root)
            } else {
                dir.join(path_part)
            };
            let Some(dest) = normalize(&dest) else {
                failures.push(format!("{at}: link `{target}` climbs above the file system root"));
                continue;
            };
            if !dest.starts_with(root) {
                failures.push(format!(
                    "{at}: link `{target}` leaves the repository ({})",
                    dest.display()
                ));
                continue;
            }
            if !dest.exists() {
                failures.push(format!("{at}: link `{target}`: no such file {}", rel(root, &dest)));
                continue;
            }
            let Some(fragment) = fragment else { continue };
            if dest.extension().is_none_or(|x| x != "md") {
                continue;
            }
            tally.anchors += 1;
            let known = anchor_cache.entry(dest.clone()).or_insert_with(|| {
                anchors(&std::fs::read_to_string(&dest).unwrap_or_else(|e| panic!("reading {}: {e}", dest.display())))
            });
            if !known.contains(fragment) {
                let mut near: Vec<&String> = known
                    .iter()
                    .filter(|a| a.contains(fragment) || fragment.contains(*a))
                    .collect();
                near.truncate(3);
                failures.push(format!(
                    "{at}: link `{target}`: {} has no heading with the anchor `#{fragment}`{}",
                    rel(root, &dest),
                    if near.is_empty() {
                        String::new()
                    } else {
                        format!(" (near: {near:?})")
                    }
                ));
            }
        }
    }
}

/// The chapters `SUMMARY.md` lists against the Markdown files under its directory.
fn check_summary(root: &Path, src: &Path, failures: &mut Vec<String>) -> usize {
    let summary = src.join("SUMMARY.md");
    let text = std::fs::read_to_string(&summary).unwrap_or_else(|e| panic!("reading {}: {e}", summary.display()));
    let parsed = parse(&text);
    let mut listed = BTreeSet::new();
    for (i, line) in without_code_spans(&parsed.prose).iter().enumerate() {
        for target in link_targets(line) {
            if target.is_empty() || is_external(&target) {
                continue; // a draft chapter `[Title]()` has no file
            }
            let path = target.split('#').next().unwrap_or_default();
            match normalize(&src.join(path)) {
                Some(p) if p.is_file() => {
                    listed.insert(p);
                }
                _ => failures.push(format!(
                    "{}:{}: chapter `{target}` does not exist",
                    rel(root, &summary),
                    i + 1
                )),
            }
        }
    }
    for file in markdown_files(src) {
        if file != summary && !listed.contains(&file) {
            failures.push(format!("{}: not listed in {}", rel(root, &file), rel(root, &summary)));
        }
    }
    listed.len()
}

// ---------------------------------------------------------------------------------------------
// Commands in code blocks.

/// A shell line as words and the operators between commands (`|`, `||`, `&&`, `;`, `&`), with
/// quotes honoured and a `#` comment dropped. Good enough for documentation, not a shell.
fn shell_commands(line: &str) -> Vec<Vec<String>> {
    let mut commands = vec![Vec::new()];
    let mut word = String::new();
    let mut in_word = false;
    let mut chars = line.chars().peekable();
    let finish = |word: &mut String, in_word: &mut bool, commands: &mut Vec<Vec<String>>| {
        if *in_word {
            commands.last_mut().expect("a command").push(std::mem::take(word));
            *in_word = false;
        }
    };
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                in_word = true;
                for q in chars.by_ref() {
                    if q == c {
                        break;
                    }
                    word.push(q);
                }
            }
            '\\' => {
                in_word = true;
                if let Some(n) = chars.next() {
                    word.push(n);
                }
            }
            '#' if !in_word => break,
            '|' | '&' | ';' => {
                finish(&mut word, &mut in_word, &mut commands);
                if chars.peek().is_some_and(|&n| n == c) {
                    chars.next();
                }
                commands.push(Vec::new());
            }
            c if c.is_whitespace() => finish(&mut word, &mut in_word, &mut commands),
            c => {
                in_word = true;
                word.push(c);
            }
        }
    }
    finish(&mut word, &mut in_word, &mut commands);
    commands.retain(|c| !c.is_empty());
    commands
}

/// The arguments given to `pbd` by one command, if it runs `pbd`: `pbd ARGS`, or
/// `cargo run … -p pbd-cli … -- ARGS`; leading `VAR=value` assignments are skipped.
fn pbd_args(words: &[String]) -> Option<Vec<String>> {
    let is_assignment = |w: &String| {
        w.split_once('=').is_some_and(|(name, _)| {
            !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') && !name.starts_with('-')
        })
    };
    let words: Vec<String> = words.iter().skip_while(|w| is_assignment(w)).cloned().collect();
    match words.first().map(String::as_str) {
        Some("pbd") => Some(words[1..].to_vec()),
        Some("cargo") if words.get(1).is_some_and(|w| w == "run") => {
            let split = words.iter().position(|w| w == "--")?;
            let cargo_args = &words[..split];
            let names_cli = cargo_args
                .windows(2)
                .any(|w| (w[0] == "-p" || w[0] == "--package") && w[1] == "pbd-cli")
                || cargo_args.iter().any(|w| w == "--package=pbd-cli");
            names_cli.then(|| words[split + 1..].to_vec())
        }
        _ => None,
    }
}

/// The subcommand path of `pbd ARGS`: the words before the first that starts with `-` or holds `/`,
/// `.` or `<` (a file, a placeholder); also `[`, `(`, `$`, `*`, `{`, `=`, `|` end it.
fn subcommand_words(args: &[String]) -> Vec<String> {
    args.iter()
        .take_while(|w| !w.starts_with('-') && !w.contains(['/', '.', '<', '[', '(', '$', '*', '{', '=', '|']))
        .cloned()
        .collect()
}

/// The long flags of `pbd ARGS` (`--name`, `--name=value` → `--name`); a bare `--` is not one.
fn long_flags(args: &[String]) -> Vec<String> {
    args.iter()
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .map(|w| w.split('=').next().unwrap_or(w).to_string())
        .collect()
}

/// Whether `flag` appears in `help` as a whole flag (not as the start of a longer one).
fn help_mentions(help: &str, flag: &str) -> bool {
    help.match_indices(flag).any(|(i, _)| {
        let next = help[i + flag.len()..].chars().next();
        let prev = help[..i].chars().next_back();
        !next.is_some_and(|c| c.is_alphanumeric() || c == '-' || c == '_')
            && !prev.is_some_and(|c| c.is_alphanumeric() || c == '-')
    })
}

/// Runs `pbd WORDS --help`: (success, help text).
type AskHelp = Box<dyn Fn(&[String]) -> (bool, String)>;

/// `pbd WORDS --help` as (success, help text), asked once per subcommand path.
struct Helper {
    cache: BTreeMap<Vec<String>, (bool, String)>,
    run: AskHelp,
}

impl std::fmt::Debug for Helper {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Helper").field("asked", &self.cache.len()).finish()
    }
}

impl Helper {
    fn binary() -> Self {
        Helper {
            cache: BTreeMap::new(),
            run: Box::new(|words| {
                let out = Command::new(env!("CARGO_BIN_EXE_pbd"))
                    .args(words)
                    .arg("--help")
                    .output()
                    .expect("the pbd binary runs");
                let text = format!(
                    "{}{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                );
                (out.status.success(), text)
            }),
        }
    }

    fn help(&mut self, words: &[String]) -> &(bool, String) {
        let run = &self.run;
        self.cache.entry(words.to_vec()).or_insert_with(|| run(words))
    }
}

const COMMAND_FENCES: [&str; 5] = ["", "sh", "bash", "shell", "console"];

/// Checks the `pbd …` command lines in the code blocks of one Markdown file.
fn check_commands(
    root: &Path,
    file: &Path,
    text: &str,
    helper: &mut Helper,
    tally: &mut Tally,
    failures: &mut Vec<String>,
) {
    for fence in parse(text).fences {
        if fence.info == "text" {
            check_synopses(
                root,
                file,
                &fence.lines,
                helper,
                &mut tally.synopses,
                &mut tally.flags,
                failures,
            );
            continue;
        }
        if !COMMAND_FENCES.contains(&fence.info.as_str()) {
            continue;
        }
        // Join continued lines (`\` at the end), keeping the number of the first.
        let mut logical: Vec<(usize, String)> = Vec::new();
        let mut pending: Option<(usize, String)> = None;
        for (number, line) in &fence.lines {
            let (n, mut acc) = pending.take().unwrap_or((*number, String::new()));
            let trimmed = line.trim_end();
            if let Some(cont) = trimmed.strip_suffix('\\') {
                acc.push_str(cont);
                acc.push(' ');
                pending = Some((n, acc));
            } else {
                acc.push_str(trimmed);
                logical.push((n, acc));
            }
        }
        logical.extend(pending);
        for (number, line) in logical {
            let line = line.trim_start();
            let line = line.strip_prefix("$ ").unwrap_or(line);
            let at = format!("{}:{number}", rel(root, file));
            for words in shell_commands(line) {
                let Some(args) = pbd_args(&words) else { continue };
                tally.commands += 1;
                let path = subcommand_words(&args);
                let shown = if path.is_empty() {
                    "pbd".to_string()
                } else {
                    format!("pbd {}", path.join(" "))
                };
                let (ok, help) = helper.help(&path).clone();
                if !ok {
                    let first = help.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
                    failures.push(format!("{at}: `{shown} --help` fails: {first}"));
                    continue;
                }
                for flag in long_flags(&args) {
                    tally.flags += 1;
                    if !help_mentions(&help, &flag) {
                        failures.push(format!("{at}: `{shown}` has no option `{flag}` (see `{shown} --help`)"));
                    }
                }
            }
        }
    }
}

/// The long flags a synopsis names anywhere on its line (`[--x N]`, `-o|--out`, `(--a | --b)`).
fn synopsis_flags(line: &str) -> Vec<String> {
    let chars: Vec<char> = line.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 2 < chars.len() {
        let starts = chars[i] == '-'
            && chars[i + 1] == '-'
            && chars[i + 2].is_ascii_alphanumeric()
            && (i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '-'));
        if starts {
            let end = (i + 2..chars.len())
                .find(|&k| !(chars[k].is_ascii_alphanumeric() || chars[k] == '-'))
                .unwrap_or(chars.len());
            out.push(chars[i..end].iter().collect());
            i = end;
        } else {
            i += 1;
        }
    }
    out
}

/// The synopses in ```text blocks (`pbd record [--scene S] … -o demo.mcap`): the subcommand path
/// ends at the first word that is a placeholder (`FILE`) or bracketed, and every long flag anywhere on
/// the line must be in that path's `--help`; `|` there means "or", not a pipe.
fn check_synopses(
    root: &Path,
    file: &Path,
    lines: &[(usize, String)],
    helper: &mut Helper,
    counter: &mut usize,
    tally_flags: &mut usize,
    failures: &mut Vec<String>,
) {
    for (number, line) in lines {
        let Some(rest) = line.trim().strip_prefix("pbd ") else {
            continue;
        };
        *counter += 1;
        let words: Vec<String> = rest.split_whitespace().map(str::to_string).collect();
        let mut path: Vec<String> = subcommand_words(&words)
            .into_iter()
            .take_while(|w| {
                !w.chars()
                    .all(|c| c.is_ascii_uppercase() || c == '_' || c.is_ascii_digit())
            })
            .take_while(|w| !w.contains('…'))
            .collect();
        if path.first().is_some_and(|w| w == "help") {
            path.remove(0); // `pbd help X` is `pbd X --help`
        }
        let shown = format!("pbd {}", path.join(" "));
        let at = format!("{}:{number}", rel(root, file));
        let (ok, help) = helper.help(&path).clone();
        if !ok {
            let first = help.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
            failures.push(format!("{at}: `{shown} --help` fails: {first}"));
            continue;
        }
        for flag in synopsis_flags(line) {
            *tally_flags += 1;
            if !help_mentions(&help, &flag) {
                failures.push(format!("{at}: `{shown}` has no option `{flag}` (see `{shown} --help`)"));
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------

#[test]
fn readme_and_book_links_chapters_and_commands() {
    let root = repo();
    let src = root.join("docs/src");
    assert!(root.join("docs/book.toml").is_file(), "docs/book.toml is missing");
    let mut failures = Vec::new();
    let mut tally = Tally::default();
    let chapters = check_summary(&root, &src, &mut failures);

    let mut files = vec![root.join("README.md")];
    files.extend(markdown_files(&src));
    let mut helper = Helper::binary();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap_or_else(|e| panic!("reading {}: {e}", file.display()));
        check_links(&root, file, &text, &mut tally, &mut failures);
        check_commands(&root, file, &text, &mut helper, &mut tally, &mut failures);
        let (_, spans) = split_code_spans(&parse(&text).prose);
        check_synopses(
            &root,
            file,
            &spans,
            &mut helper,
            &mut tally.spans,
            &mut tally.flags,
            &mut failures,
        );
    }

    println!(
        "{} files, {chapters} chapters in SUMMARY.md; {} relative links ({} with an anchor), {} external \
         links not followed; {} `pbd` command lines in code blocks, {} synopses, {} inline `pbd …` spans \
         ({} subcommand paths asked for --help), {} long flags",
        files.len(),
        tally.links,
        tally.anchors,
        tally.external,
        tally.commands,
        tally.synopses,
        tally.spans,
        helper.cache.len(),
        tally.flags
    );
    let mut report = String::new();
    for f in &failures {
        let _ = writeln!(report, "  {f}");
    }
    assert!(
        failures.is_empty(),
        "{} problems in the README and the book:\n{report}",
        failures.len()
    );
    // A parser that finds nothing would pass silently.
    assert!(chapters >= 10, "only {chapters} chapters found in SUMMARY.md");
    assert!(tally.links >= 30, "only {} relative links found", tally.links);
    assert!(tally.anchors >= 5, "only {} anchors found", tally.anchors);
    assert!(tally.commands >= 15, "only {} pbd commands found", tally.commands);
    assert!(tally.synopses >= 10, "only {} synopses found", tally.synopses);
    assert!(tally.spans >= 20, "only {} inline pbd spans found", tally.spans);
}

// ---------------------------------------------------------------------------------------------
// The checker catches what it should (so the test above can fail).

#[test]
fn slugs_follow_github_and_mdbook() {
    assert_eq!(slug("Quick start"), "quick-start");
    assert_eq!(
        slug("The robot and the world (`dexter`, `dexter-sim`)"),
        "the-robot-and-the-world-dexter-dexter-sim"
    );
    assert_eq!(
        slug("Teleoperation streams (CSV or JSON lines)"),
        "teleoperation-streams-csv-or-json-lines"
    );
    assert_eq!(slug("`pbd experiment sorting`"), "pbd-experiment-sorting");
    assert_eq!(slug("pbd — teleological"), "pbd--teleological");
    assert_eq!(slug("A [link](x.md) in_it"), "a-link-in_it");
    let a = anchors("# A\n\n```sh\n# not a heading\n```\n## A\n### B #\n");
    assert_eq!(a, ["a", "a-1", "b"].into_iter().map(String::from).collect());
}

#[test]
fn broken_links_and_anchors_are_reported() {
    let root = std::env::temp_dir().join(format!("pbd-docs-book-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(root.join("docs/src")).unwrap();
    let root = root.canonicalize().unwrap();
    std::fs::write(root.join("docs/src/other.md"), "# Other\n\n## Some part\n").unwrap();
    let text = "# Page\n\n[ok](other.md#some-part) [ok](#page) [web](https://example.org/x.md)\n\
                [gone](missing.md) and `[code](not-a-link.md)`\n[bad anchor](other.md#no-part)\n\
                ```sh\n[in a fence](nope.md)\n```\n[outside](../../../elsewhere.md) [self](#nothing)\n";
    let file = root.join("docs/src/page.md");
    std::fs::write(&file, text).unwrap();
    let mut failures = Vec::new();
    let mut tally = Tally::default();
    check_links(&root, &file, text, &mut tally, &mut failures);
    std::fs::write(
        root.join("docs/src/SUMMARY.md"),
        "# Summary\n\n- [Page](page.md)\n- [Gone](gone.md)\n",
    )
    .unwrap();
    let chapters = check_summary(&root, &root.join("docs/src"), &mut failures);
    let _ = std::fs::remove_dir_all(&root);
    let all = failures.join("\n");
    assert_eq!(chapters, 1, "{all}");
    assert_eq!(failures.len(), 6, "{all}");
    assert!(
        all.contains("docs/src/page.md:4: link `missing.md`: no such file"),
        "{all}"
    );
    assert!(all.contains("docs/src/page.md:5: link `other.md#no-part`"), "{all}");
    assert!(
        all.contains("docs/src/page.md:9: link `../../../elsewhere.md` leaves the repository"),
        "{all}"
    );
    assert!(all.contains("docs/src/page.md:9: link `#nothing`"), "{all}");
    assert!(all.contains("SUMMARY.md:4: chapter `gone.md` does not exist"), "{all}");
    assert!(all.contains("docs/src/other.md: not listed in"), "{all}");
    assert_eq!(tally.external, 1);
}

#[test]
fn wrong_commands_and_flags_are_reported() {
    let text = "```sh\n$ pbd robot info --json | jq '.name --nope'   # a comment --nope\n\
                pbd robot nosuch --json\npbd robot fk --base a --tip b --q=-0.5 --nope \\\n    --degrees\n\
                PBD_X=1 cargo run --release -p pbd-cli -- robot info --jsn && pbd robot info x.urdf\n```\n\
                ```text\npbd robot nosuch\npbd robot fk [URDF] --base LINK [--q V1,…] (--degrees | --radians)\n\
                pbd robot info FILE [-o|--json]\nt,hand,x\n```\n";
    let mut helper = Helper {
        cache: BTreeMap::new(),
        run: Box::new(|words| match words.join(" ").as_str() {
            "" | "robot" => (true, "Usage: pbd [OPTIONS] <COMMAND>\n      --threads <N>\n".into()),
            "robot info" => (true, "Usage: pbd robot info [URDF]\n      --json  as JSON\n".into()),
            "robot fk" => (
                true,
                "      --base <B>\n      --tip <T>\n      --q <Q>\n      --degrees\n".into(),
            ),
            other => (false, format!("error: unrecognized subcommand '{other}'")),
        }),
    };
    let root = Path::new("/repo");
    let mut failures = Vec::new();
    let mut tally = Tally::default();
    check_commands(root, &root.join("doc.md"), text, &mut helper, &mut tally, &mut failures);
    let all = failures.join("\n");
    assert_eq!((tally.commands, tally.synopses), (5, 3), "{all}");
    let prose =
        parse("Run `pbd robot fk --nope` or ``pbd help robot``, `pbd …`\nand `pbd robot\ninfo --json`.\n").prose;
    let (_, spans) = split_code_spans(&prose);
    check_synopses(
        root,
        &root.join("doc.md"),
        &spans,
        &mut helper,
        &mut tally.spans,
        &mut tally.flags,
        &mut failures,
    );
    let all = failures.join("\n");
    assert_eq!(tally.spans, 4, "{all}");
    assert!(all.contains("doc.md:1: `pbd robot fk` has no option `--nope`"), "{all}");
    assert_eq!(failures.len(), 6, "{all}");
    assert!(all.contains("doc.md:9: `pbd robot nosuch --help` fails"), "{all}");
    assert!(
        all.contains("doc.md:10: `pbd robot fk` has no option `--radians`"),
        "{all}"
    );
    assert!(all.contains("doc.md:3: `pbd robot nosuch --help` fails"), "{all}");
    assert!(all.contains("doc.md:4: `pbd robot fk` has no option `--nope`"), "{all}");
    assert!(
        all.contains("doc.md:6: `pbd robot info` has no option `--jsn`"),
        "{all}"
    );
}
