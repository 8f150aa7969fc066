//! Scripted sessions: a text file of timed input events, replayed through the window's own
//! input handling (they are injected as egui pointer, wheel and key events before each frame,
//! exactly where the real mouse and keyboard events arrive).
//!
//! One command per line; `#` starts a comment. Positions are normalised coordinates in the 3D
//! view: (0, 0) is its top-left corner, (1, 1) its bottom-right.
//!
//! | command | effect |
//! |---|---|
//! | `wait SECONDS` | do nothing for this long (wall clock) |
//! | `wait_frames N` | do nothing for N displayed frames |
//! | `wait_sim SECONDS` | wait until the simulated time reaches this value; `wait_sim +SECONDS` waits for that much simulated time from now |
//! | `move X Y` | move the mouse (no button) |
//! | `pick X Y` | move the mouse there and press the left button (in pick mode: grabs the particle under it) |
//! | `pick_particle I J` | the same, at the screen position of grid particle (column I, row J) |
//! | `pick_particle K` | the same, at particle K (from 0; on a mesh cloth the file's vertex K, on the grid `J * NX + I`) |
//! | `drag_to X Y [FRAMES]` | move the pressed mouse to X Y in a straight line over FRAMES frames (default 30) |
//! | `wheel NOTCHES` | turn the wheel (positive: away from the user; while dragging this lifts the particle) |
//! | `pin` | right click (while dragging: pins the particle where it is) |
//! | `release` | release the left button |
//! | `key NAME` | press and release a key: a letter, a digit, `Space`, `Period`, `Escape`, `F1`... |
//! | `screenshot PATH` | save the window as a PNG |
//! | `report` | print the readouts as one line on stdout (for measuring real time) |
//! | `report_particle K` (or `I J` on the grid) | print the particle's position as one line on stdout: `wetcloth: particle K at X Y Z m` |
//! | `quit` | close the window |

use std::path::{Path, PathBuf};

/// One scripted command.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Wait for this many wall-clock seconds.
    Wait(f64),
    /// Wait for this many displayed frames.
    WaitFrames(u32),
    /// Wait for simulated time.
    WaitSim {
        /// Simulated time, s.
        time: f64,
        /// Whether `time` counts from when the command starts rather than from t = 0.
        relative: bool,
    },
    /// Move the mouse to a normalised view position, no button.
    Move([f32; 2]),
    /// Move there and press the left button.
    Pick([f32; 2]),
    /// Press the left button on a particle.
    PickParticle(ParticleRef),
    /// Drag the pressed mouse to a normalised position over a number of frames.
    DragTo {
        /// Where to, normalised.
        to: [f32; 2],
        /// Frames the move takes (>= 1).
        frames: u32,
    },
    /// Turn the mouse wheel by this many notches.
    Wheel(f32),
    /// Right click.
    Pin,
    /// Release the left button.
    Release,
    /// Press and release a key (egui key name).
    Key(String),
    /// Save a screenshot.
    Screenshot(PathBuf),
    /// Print the readouts (wall-clock and simulated time, real-time factor, steps and frames
    /// a second, hand force) as one line on stdout.
    Report,
    /// Print a particle's position as one line on stdout.
    ReportParticle(ParticleRef),
    /// Close the window.
    Quit,
}

/// A particle a script names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParticleRef {
    /// Its index, from 0 (any cloth: on a mesh cloth the file's vertex).
    Index(usize),
    /// Grid column and row (the built-in grid only).
    Grid([usize; 2]),
}

impl std::fmt::Display for ParticleRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Index(k) => write!(f, "{k}"),
            Self::Grid([i, j]) => write!(f, "({i}, {j})"),
        }
    }
}

/// A script that could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    /// The file could not be read.
    #[error("cannot read script {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A line is not a command.
    #[error("script line {line}: {message}")]
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Reads a script file.
pub fn load(path: &Path) -> Result<Vec<Command>, ScriptError> {
    let text = std::fs::read_to_string(path).map_err(|source| ScriptError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&text)
}

/// Parses script text.
pub fn parse(text: &str) -> Result<Vec<Command>, ScriptError> {
    let mut out = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let err = |message: String| ScriptError::Syntax {
            line: n + 1,
            message,
        };
        let mut words = line.split_whitespace();
        let name = words.next().unwrap_or_default();
        let args: Vec<&str> = words.collect();
        let want = |count: std::ops::RangeInclusive<usize>, usage: &str| {
            if count.contains(&args.len()) {
                Ok(())
            } else {
                Err(err(format!("usage: {usage}")))
            }
        };
        let num = |i: usize| -> Result<f64, ScriptError> {
            args[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| err(format!("`{}` is not a number", args[i])))
        };
        let pos = |usage: &str| -> Result<[f32; 2], ScriptError> {
            let (x, y) = (num(0)?, num(1)?);
            if !(-0.5..=1.5).contains(&x) || !(-0.5..=1.5).contains(&y) {
                return Err(err(format!(
                    "{usage}: X and Y are normalised view coordinates (0..1)"
                )));
            }
            Ok([x as f32, y as f32])
        };
        let cmd = match name {
            "wait" => {
                want(1..=1, "wait SECONDS")?;
                Command::Wait(num(0)?.max(0.0))
            }
            "wait_frames" => {
                want(1..=1, "wait_frames N")?;
                Command::WaitFrames(num(0)?.max(0.0) as u32)
            }
            "wait_sim" => {
                want(1..=1, "wait_sim [+]SECONDS")?;
                Command::WaitSim {
                    time: num(0)?,
                    relative: args[0].starts_with('+'),
                }
            }
            "move" => {
                want(2..=2, "move X Y")?;
                Command::Move(pos("move X Y")?)
            }
            "pick" => {
                want(2..=2, "pick X Y")?;
                Command::Pick(pos("pick X Y")?)
            }
            "pick_particle" => {
                Command::PickParticle(particle_ref(&args, "pick_particle").map_err(err)?)
            }
            "report_particle" => {
                Command::ReportParticle(particle_ref(&args, "report_particle").map_err(err)?)
            }
            "drag_to" => {
                want(2..=3, "drag_to X Y [FRAMES]")?;
                let frames = if args.len() == 3 {
                    num(2)?.max(1.0) as u32
                } else {
                    30
                };
                Command::DragTo {
                    to: pos("drag_to X Y [FRAMES]")?,
                    frames,
                }
            }
            "wheel" => {
                want(1..=1, "wheel NOTCHES")?;
                Command::Wheel(num(0)? as f32)
            }
            "pin" => {
                want(0..=0, "pin")?;
                Command::Pin
            }
            "release" => {
                want(0..=0, "release")?;
                Command::Release
            }
            "key" => {
                want(1..=1, "key NAME")?;
                if key_from_name(args[0]).is_none() {
                    return Err(err(format!(
                        "unknown key `{}` (letters, digits, Space, Period, Escape, F1...)",
                        args[0]
                    )));
                }
                Command::Key(args[0].to_string())
            }
            "screenshot" => {
                if args.is_empty() {
                    return Err(err("usage: screenshot PATH".into()));
                }
                // The rest of the line, so paths may contain spaces.
                let rest = line["screenshot".len()..].trim();
                Command::Screenshot(PathBuf::from(rest))
            }
            "report" => {
                want(0..=0, "report")?;
                Command::Report
            }
            "quit" => {
                want(0..=0, "quit")?;
                Command::Quit
            }
            other => {
                return Err(err(format!(
                    "unknown command `{other}` (wait, wait_frames, wait_sim, move, pick, \
                     pick_particle, drag_to, wheel, pin, release, key, screenshot, report, \
                     report_particle, quit)"
                )));
            }
        };
        out.push(cmd);
    }
    Ok(out)
}

/// The particle of a command's arguments: `K` (an index) or `COLUMN ROW` (on the grid).
fn particle_ref(args: &[&str], name: &str) -> Result<ParticleRef, String> {
    let numbers: Vec<_> = args.iter().map(|a| a.parse::<usize>()).collect();
    match numbers.as_slice() {
        [Ok(k)] => Ok(ParticleRef::Index(*k)),
        [Ok(i), Ok(j)] => Ok(ParticleRef::Grid([*i, *j])),
        [_] => Err(format!("{name} K: K is a particle index (0, 1, ...)")),
        [_, _] => Err(format!(
            "{name} COLUMN ROW: COLUMN and ROW are grid indices (0, 1, ...)"
        )),
        _ => Err(format!("usage: {name} K, or {name} COLUMN ROW on the grid")),
    }
}

/// The egui key of a script key name: a letter or digit, or an egui key name (`Space`,
/// `Period`, `Escape`, `F1`, ...).
pub fn key_from_name(name: &str) -> Option<eframe::egui::Key> {
    use eframe::egui::Key;
    if name == "." {
        return Some(Key::Period);
    }
    if name.len() == 1 {
        return Key::from_name(&name.to_ascii_uppercase());
    }
    Key::from_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command() {
        let s = parse(
            "# lift the centre\n\
             wait 0.5\nwait_frames 3\nwait_sim 0.2\nwait_sim +0.1\nmove 0.1 0.2\npick 0.5 0.5\n\
             pick_particle 25 25\ndrag_to 0.5 0.3 20  # up\ndrag_to 0.4 0.3\nwheel -2\npin\n\
             release\nkey A\nkey .\nkey Space\nscreenshot out dir/shot.png\nquit\n\
             pick_particle 300\nreport_particle 7\nreport_particle 1 2\n",
        )
        .unwrap();
        assert_eq!(s.len(), 20);
        assert_eq!(s[17], Command::PickParticle(ParticleRef::Index(300)));
        assert_eq!(s[18], Command::ReportParticle(ParticleRef::Index(7)));
        assert_eq!(s[19], Command::ReportParticle(ParticleRef::Grid([1, 2])));
        assert_eq!(s[0], Command::Wait(0.5));
        assert_eq!(
            s[3],
            Command::WaitSim {
                time: 0.1,
                relative: true
            }
        );
        let s = &s[1..];
        assert_eq!(s[5], Command::PickParticle(ParticleRef::Grid([25, 25])));
        assert_eq!(
            s[6],
            Command::DragTo {
                to: [0.5, 0.3],
                frames: 20
            }
        );
        assert_eq!(
            s[7],
            Command::DragTo {
                to: [0.4, 0.3],
                frames: 30
            }
        );
        assert_eq!(s[8], Command::Wheel(-2.0));
        assert_eq!(
            s[14],
            Command::Screenshot(PathBuf::from("out dir/shot.png"))
        );
        assert_eq!(s[15], Command::Quit);
    }

    #[test]
    fn report_takes_no_arguments() {
        assert_eq!(parse("report\n").unwrap(), vec![Command::Report]);
        let e = parse("report now\n").unwrap_err().to_string();
        assert!(e.contains("usage: report"), "{e}");
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("wait 1\n\nfly 2\n").unwrap_err().to_string();
        assert!(
            e.contains("line 3") && e.contains("unknown command `fly`"),
            "{e}"
        );
        let e = parse("pick 0.5\n").unwrap_err().to_string();
        assert!(e.contains("usage: pick X Y"), "{e}");
        let e = parse("key Banana\n").unwrap_err().to_string();
        assert!(e.contains("unknown key"), "{e}");
        let e = parse("wait soon\n").unwrap_err().to_string();
        assert!(e.contains("not a number"), "{e}");
        let e = parse("pick_particle\n").unwrap_err().to_string();
        assert!(e.contains("usage: pick_particle K"), "{e}");
        let e = parse("report_particle -1\n").unwrap_err().to_string();
        assert!(e.contains("particle index"), "{e}");
    }

    #[test]
    fn key_names() {
        use eframe::egui::Key;
        assert_eq!(key_from_name("a"), Some(Key::A));
        assert_eq!(key_from_name("."), Some(Key::Period));
        assert_eq!(key_from_name("Space"), Some(Key::Space));
        assert_eq!(key_from_name("F1"), Some(Key::F1));
    }
}
