//! The bodies `POST /tonemap` is receiving, bounded apart from the tone-map
//! queues: at most `max_uploads` at once, holding at most `upload_budget`
//! bytes together, each charged as its bytes arrive (a client that sends
//! slowly holds only what it has sent). A queue place is taken only once a
//! body is in, so clients that send slowly hold no worker and no place.
//! One client (a peer address, or the address a trusted proxy forwarded
//! for) may hold at most a share of either bound, so that its slow uploads
//! cannot deny the rest (`serve --max-uploads-per-client`).

use super::error::ApiError;
use axum::body::Bytes;
use axum::http::StatusCode;
use futures_util::StreamExt;
use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// What the server is receiving now.
pub struct Uploads {
    most: usize,
    budget: u64,
    /// The most uploads one client may have open at once; its bytes are
    /// bounded to the same share of the budget.
    per_client: usize,
    open: AtomicUsize,
    held: AtomicU64,
    /// Each client's open uploads and the bytes they hold.
    clients: Mutex<HashMap<Client, (usize, u64)>>,
    /// Uploads refused for either bound, for `/metrics`.
    pub refused: AtomicU64,
}

/// One body being received; its place and bytes are given back when it is
/// dropped (read, refused, cut off or timed out).
pub struct Upload {
    of: Arc<Uploads>,
    held: u64,
    client: Option<Client>,
}

impl Uploads {
    pub fn new(most: usize, budget: usize) -> Arc<Uploads> {
        Uploads::with_share(most, budget, most)
    }

    /// [`Uploads::new`] with at most `per_client` uploads, and that share
    /// of the byte budget, to one client.
    pub fn with_share(most: usize, budget: usize, per_client: usize) -> Arc<Uploads> {
        let most = most.max(1);
        Arc::new(Uploads {
            most,
            budget: budget as u64,
            per_client: per_client.clamp(1, most),
            open: AtomicUsize::new(0),
            held: AtomicU64::new(0),
            clients: Mutex::new(HashMap::new()),
            refused: AtomicU64::new(0),
        })
    }

    /// The bytes one client may hold: its share of the budget.
    fn client_bytes(&self) -> u64 {
        (self.budget as u128 * self.per_client as u128 / self.most as u128) as u64
    }

    /// A place for one more body from `client`, or 503 `busy` when the
    /// client has its share of places, or `max_uploads` are being received.
    pub fn begin_for(self: &Arc<Self>, client: Option<Client>) -> Result<Upload, ApiError> {
        if let Some(ip) = client {
            let mut clients = self.clients.lock().unwrap_or_else(|p| p.into_inner());
            let entry = clients.entry(ip).or_insert((0, 0));
            if entry.0 >= self.per_client {
                self.refused.fetch_add(1, Ordering::Relaxed);
                return Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "this client has {} uploads in progress, the most one client may                          (serve --max-uploads-per-client); send it when one has ended",
                        entry.0
                    ),
                    1,
                ));
            }
            entry.0 += 1;
        }
        let mut upload = self.begin()?;
        upload.client = client;
        Ok(upload)
    }

    /// Bodies being received now, and the bytes they hold.
    pub fn now(&self) -> (usize, u64) {
        (
            self.open.load(Ordering::Relaxed),
            self.held.load(Ordering::Relaxed),
        )
    }

    /// A place for one more body, or 503 `busy` when `max_uploads` are
    /// being received.
    pub fn begin(self: &Arc<Self>) -> Result<Upload, ApiError> {
        let taken = self
            .open
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n < self.most).then_some(n + 1)
            });
        match taken {
            Ok(_) => Ok(Upload {
                of: self.clone(),
                held: 0,
                client: None,
            }),
            Err(n) => {
                self.refused.fetch_add(1, Ordering::Relaxed);
                Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "{n} uploads are being received, the most at once (serve --max-uploads); \
                         send it again"
                    ),
                    1,
                ))
            }
        }
    }
}

impl Upload {
    /// Charges `n` more bytes of this body to the budget, or 503 `busy`
    /// when the uploads in progress hold it all.
    pub fn charge(&mut self, n: usize) -> Result<(), ApiError> {
        let n = n as u64;
        let budget = self.of.budget;
        if let Some(ip) = self.client {
            let share = self.of.client_bytes();
            let mut clients = self.of.clients.lock().unwrap_or_else(|p| p.into_inner());
            let entry = clients.entry(ip).or_insert((0, 0));
            if entry.1 + n > share {
                self.of.refused.fetch_add(1, Ordering::Relaxed);
                return Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "this client's uploads in progress hold {:.1} MiB, the most one client may \
                         ({:.1} MiB: serve --max-uploads-per-client of --max-uploads); send it again",
                        entry.1 as f64 / 1048576.0,
                        share as f64 / 1048576.0
                    ),
                    1,
                ));
            }
            entry.1 += n;
        }
        let charged = self
            .of
            .held
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |h| {
                (h + n <= budget).then_some(h + n)
            });
        match charged {
            Ok(_) => {
                self.held += n;
                Ok(())
            }
            Err(h) => {
                self.of.refused.fetch_add(1, Ordering::Relaxed);
                if let Some(ip) = self.client {
                    let mut clients = self.of.clients.lock().unwrap_or_else(|p| p.into_inner());
                    if let Some(e) = clients.get_mut(&ip) {
                        e.1 = e.1.saturating_sub(n);
                    }
                }
                Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "the uploads in progress hold {:.1} MiB of the {:.1} MiB they may \
                         (serve --upload-budget-mib); send it again",
                        h as f64 / 1048576.0,
                        budget as f64 / 1048576.0
                    ),
                    1,
                ))
            }
        }
    }
}

impl Drop for Upload {
    fn drop(&mut self) {
        self.of.held.fetch_sub(self.held, Ordering::AcqRel);
        self.of.open.fetch_sub(1, Ordering::AcqRel);
        if let Some(ip) = self.client {
            let mut clients = self.of.clients.lock().unwrap_or_else(|p| p.into_inner());
            if let Some(e) = clients.get_mut(&ip) {
                e.0 = e.0.saturating_sub(1);
                e.1 = e.1.saturating_sub(self.held);
                if e.0 == 0 {
                    clients.remove(&ip);
                }
            }
        }
    }
}

/// The peer address of a request's connection, as the accept loop saw it.
#[derive(Clone, Copy, Debug)]
pub struct Peer(pub IpAddr);

/// Whose uploads are counted together: a token's holder (a CI job), apart
/// from whatever shares its address, or else an address.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Client {
    Token(super::Scope),
    Address(IpAddr),
}

impl super::AppState {
    /// The client a request's upload is counted against: its token's, when
    /// it carries one of the server's, else its address ([`client_of`]).
    pub fn upload_client(
        &self,
        extensions: &axum::http::Extensions,
        headers: &axum::http::HeaderMap,
    ) -> Option<Client> {
        match self.token_of(headers) {
            Some(scope) => Some(Client::Token(scope)),
            None => {
                client_of(extensions, headers, &self.limits.trusted_proxies).map(Client::Address)
            }
        }
    }
}

/// The client a request comes from: its peer, or, when the peer is one of
/// `trusted` proxies, the last address of `X-Forwarded-For` that is not
/// itself a trusted proxy (what the proxy saw). None for a request the
/// accept loop did not mark (the tests' in-process calls).
pub fn client_of(
    extensions: &axum::http::Extensions,
    headers: &axum::http::HeaderMap,
    trusted: &[IpAddr],
) -> Option<IpAddr> {
    let Peer(peer) = *extensions.get::<Peer>()?;
    if !trusted.contains(&peer) {
        return Some(peer);
    }
    let forwarded = headers
        .get_all("x-forwarded-for")
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .filter_map(|a| a.trim().parse::<IpAddr>().ok())
        .collect::<Vec<_>>();
    Some(
        forwarded
            .into_iter()
            .rev()
            .find(|a| !trusted.contains(a))
            .unwrap_or(peer),
    )
}

/// A raw body, at most `limit` bytes, each chunk charged to `upload` as it
/// arrives; when it is one image (`max_pixels` given), one whose header
/// states more than `max_pixels` is refused as soon as it does.
pub async fn read_raw(
    body: axum::body::Body,
    limit: usize,
    max_pixels: Option<u64>,
    upload: &mut Upload,
) -> Result<Bytes, ApiError> {
    let mut check = max_pixels.map(crate::request::head::HeadCheck::new);
    let mut stream = body.into_data_stream();
    let mut got = bytes::BytesMut::new();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| ApiError::bad(format!("reading the body: {e}")))?;
        if got.len() + chunk.len() > limit {
            return Err(ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                "too_large",
                format!("the body is over the limit of {limit} bytes (serve --max-body-mib)"),
            ));
        }
        upload.charge(chunk.len())?;
        if let Some(c) = check.as_mut() {
            c.feed(&chunk)?;
        }
        got.extend_from_slice(&chunk);
    }
    Ok(got.freeze())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn places_and_bytes_are_given_back_when_an_upload_ends() {
        let u = Uploads::new(2, 100);
        let mut a = u.begin().unwrap();
        let b = u.begin().unwrap();
        let Err(third) = u.begin() else {
            panic!("a third upload past the most of two")
        };
        assert_eq!((third.status.as_u16(), third.code), (503, "busy"));
        a.charge(60).unwrap();
        let mut b = b;
        let over = b.charge(41).unwrap_err();
        assert!(
            over.detail.contains("--upload-budget-mib"),
            "{}",
            over.detail
        );
        b.charge(40).unwrap();
        assert_eq!(u.now(), (2, 100));
        drop(a);
        assert_eq!(u.now(), (1, 40));
        let mut c = u.begin().unwrap();
        c.charge(60).unwrap();
        drop((b, c));
        assert_eq!(u.now(), (0, 0));
        assert_eq!(u.refused.load(Ordering::Relaxed), 2);
    }

    /// One client's uploads take at most its share of the places and of
    /// the bytes; another client still gets a place.
    #[test]
    fn one_client_holds_at_most_its_share() {
        let u = Uploads::with_share(8, 800, 2);
        let (a, b) = (
            Client::Address("10.0.0.1".parse().unwrap()),
            Client::Address("10.0.0.2".parse().unwrap()),
        );
        let mut first = u.begin_for(Some(a)).unwrap();
        let _second = u.begin_for(Some(a)).unwrap();
        let third = u.begin_for(Some(a)).err().expect("a third from one client");
        assert!(
            third.detail.contains("--max-uploads-per-client"),
            "{}",
            third.detail
        );
        let _other = u.begin_for(Some(b)).unwrap();
        // The share of bytes: 800 × 2 / 8.
        first.charge(200).unwrap();
        let over = first.charge(1).unwrap_err();
        assert!(over.detail.contains("one client may"), "{}", over.detail);
        drop(first);
        let _again = u.begin_for(Some(a)).unwrap();
    }
}
