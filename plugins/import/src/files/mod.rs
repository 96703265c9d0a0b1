//! The one opener of the user's files: regular files only, within the opened file's folder.

pub(crate) mod sandbox;
