//! What an API client sends, parsed and checked without a server: the
//! parameters of `POST /tonemap` and its multipart body, a `POST /runs`
//! body, the parameter names and values every endpoint takes, and the
//! error answer each refusal becomes. `server` answers with these; the fuzz
//! targets (`fuzzing`) run them as they are, without HTTP.

pub mod error;
pub mod head;
pub mod params;
pub mod runs;
pub mod tonemap;

pub use error::ApiError;

/// The most pixels an uploaded image may have by default (`serve
/// --max-pixels`): 8 Mi, 4K UHD. The fuzz targets decode under it.
pub const MAX_UPLOAD_PIXELS: u64 = 8 << 20;
