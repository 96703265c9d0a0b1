//! Messages for the user (import results, errors), shown by the UI until dismissed or expired.

use bevy::prelude::*;
use std::time::{Duration, Instant};

/// How serious a notice is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Something finished.
    Info,
    /// Something was skipped.
    Warning,
    /// Something failed.
    Error,
}

/// One notice.
#[derive(Clone, Debug)]
pub struct Notice {
    /// Severity.
    pub level: Level,
    /// Text, naming the file and the problem where there is one.
    pub text: String,
    /// When it fades; errors stay until dismissed.
    pub until: Option<Instant>,
}

/// Notices waiting to be read.
#[derive(Resource, Default, Debug)]
pub struct Notices(pub Vec<Notice>);

impl Notices {
    /// Adds an informational notice that fades after a few seconds.
    pub fn info(&mut self, text: impl Into<String>) {
        let text = text.into();
        info!("{text}");
        self.0.push(Notice {
            level: Level::Info,
            text,
            until: Some(Instant::now() + Duration::from_secs(6)),
        });
    }
    /// Adds a warning that fades after a while.
    pub fn warn(&mut self, text: impl Into<String>) {
        let text = text.into();
        warn!("{text}");
        self.0.push(Notice {
            level: Level::Warning,
            text,
            until: Some(Instant::now() + Duration::from_secs(15)),
        });
    }
    /// Whether an error is among them.
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(|n| n.level == Level::Error)
    }

    /// Adds an error that stays until dismissed.
    pub fn error(&mut self, text: impl Into<String>) {
        let text = text.into();
        error!("{text}");
        self.0.push(Notice {
            level: Level::Error,
            text,
            until: None,
        });
    }
}

impl Notices {
    /// When the next notice fades, if one will: an app that rests between frames wakes then.
    pub fn next_fade(&self) -> Option<Instant> {
        self.0.iter().filter_map(|n| n.until).min()
    }
}

/// Drops the notices whose time is up (by the clock, not by frames: a frame after a long rest
/// drops all that faded meanwhile).
pub fn expire_notices(mut notices: ResMut<Notices>) {
    let now = Instant::now();
    if notices.0.iter().any(|n| n.until.is_some_and(|t| t <= now)) {
        notices.0.retain(|n| n.until.is_none_or(|t| t > now));
    }
}
