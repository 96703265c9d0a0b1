//! Messages for the user (import results, errors), shown by the UI until dismissed or expired.

use bevy::prelude::*;

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
    /// Seconds it stays; errors stay until dismissed.
    pub ttl: Option<f32>,
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
            ttl: Some(6.0),
        });
    }
    /// Adds a warning that fades after a while.
    pub fn warn(&mut self, text: impl Into<String>) {
        let text = text.into();
        warn!("{text}");
        self.0.push(Notice {
            level: Level::Warning,
            text,
            ttl: Some(15.0),
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
            ttl: None,
        });
    }
}

/// Ages notices and drops the expired ones.
pub fn expire_notices(time: Res<Time>, mut notices: ResMut<Notices>) {
    let dt = time.delta_secs();
    if notices.0.iter().all(|n| n.ttl.is_none()) {
        return;
    }
    for n in &mut notices.0 {
        if let Some(t) = &mut n.ttl {
            *t -= dt;
        }
    }
    notices.0.retain(|n| n.ttl.is_none_or(|t| t > 0.0));
}
