//! Projects: the `.treelight` format ([`format`](mod@format)), capturing and saving the scene ([`capture`]),
//! opening one in place of the scene ([`restore`], in the background: [`open`]), what the File
//! menu and the command line ask ([`requests`]), recovery copies (written by [`autosave`], found
//! by [`recovery`]), the editors' locks ([`editor_lock`]), `--commands` scripts ([`script`]) and `treelight info` ([`info`]).

pub mod autosave;
pub mod capture;
pub mod editor_lock;
pub mod format;
pub mod info;
pub mod open;
pub(crate) mod plan;
pub mod recovery;
pub mod requests;
pub mod restore;
pub mod script;
