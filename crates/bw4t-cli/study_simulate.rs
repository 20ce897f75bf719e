//! `bw4t study STUDY.toml --simulate N`: a dry run of a study before it is posted. The
//! study is served as for real, and N scripted participants go through it as the page
//! would, over the same HTTP API and protocol port: arrival (with the cookie the server
//! sets), consent, instructions, answers to every questionnaire, each trial played by a
//! built-in agent (the trial page's hello, its start and events reported, its end
//! answered), up to the final page. The data is then exported as a real study's is.
//!
//! Participant `K` (from 1) is `sim-K`. Every tenth declines consent, so that path is in
//! the data too; answers are drawn from a generator seeded by the participant's number,
//! so a dry run gives the same answers each time.

use std::net::SocketAddr;
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, anyhow, bail};
use bw4t_agents::Strategy;
use bw4t_map::SeededRng;
use bw4t_protocol::{ParticipantState, QuestionItem, QuestionKind, SessionOptions, StudyPage};
use bytes::Bytes;
use http_body_util::{BodyExt, Full};
use hyper::{Method, Request, header};
use hyper_util::rt::TokioIo;
use serde_json::{Map, Value, json};

/// How far each simulated participant got.
#[derive(Debug, Default)]
pub(crate) struct Simulated {
    /// Reached the final page.
    pub completed: usize,
    /// Declined consent.
    pub declined: usize,
    /// Failed a pass mark (a practice round, a comprehension check) and were screened out.
    pub screened_out: usize,
    /// Trials played.
    pub trials: usize,
    /// Could not go on (an error), with why.
    pub stopped: Vec<String>,
}

/// Plays `n` participants through the study served on `web` (its pages' API) and `play`
/// (the protocol port), all at once, as people arriving together would.
pub(crate) async fn simulate(n: u32, web: SocketAddr, play: SocketAddr) -> Simulated {
    let mut runs = tokio::task::JoinSet::new();
    for k in 1..=n {
        runs.spawn(async move { (k, participant(k, web, play).await) });
    }
    let mut simulated = Simulated::default();
    while let Some(joined) = runs.join_next().await {
        match joined {
            Ok((_, Ok(Outcome { end, trials }))) => {
                simulated.trials += trials;
                match end {
                    End::Completed => simulated.completed += 1,
                    End::Declined => simulated.declined += 1,
                    End::ScreenedOut => simulated.screened_out += 1,
                }
            }
            Ok((k, Err(e))) => simulated.stopped.push(format!("sim-{k}: {e:#}")),
            Err(e) => simulated.stopped.push(format!("a participant's task failed: {e}")),
        }
    }
    simulated
}

/// Where a participant's way ended.
enum End {
    Completed,
    Declined,
    ScreenedOut,
}

struct Outcome {
    end: End,
    trials: usize,
}

/// The most steps a participant takes: far more than any study has pages (a trial given
/// again counts once more), so a study that never ends is reported, not run forever.
const MAX_STEPS: usize = 1000;

/// One participant, from arrival to the last page.
async fn participant(k: u32, web: SocketAddr, play: SocketAddr) -> Result<Outcome> {
    let browser = Browser { web, cookie: std::sync::Mutex::new(None) };
    let id = format!("sim-{k}");
    let mut rng = SeededRng::new(u64::from(k));
    let (status, arrived) = browser
        .call(Method::POST, "/api/study/participants", Some(json!({"params": {"participant": id}})))
        .await?;
    if status != 201 {
        bail!("arrival answered {status}: {arrived}");
    }
    let mut state: ParticipantState = serde_json::from_value(arrived).context("the arrival's state")?;
    let mut trials = 0;
    for _ in 0..MAX_STEPS {
        let step = state.step;
        let Some(page) = state.page.clone() else { bail!("step {step} has no page") };
        browser.events(&id, step, &[json!({"kind": "page_shown"})]).await?;
        // A practice round is played as a trial is, but is not one.
        let is_trial = matches!(page, StudyPage::Trial { .. });
        let answers = match page {
            StudyPage::Final { .. } => return Ok(Outcome { end: End::Completed, trials }),
            StudyPage::Declined { .. } => return Ok(Outcome { end: End::Declined, trials }),
            StudyPage::Consent { .. } => json!({"consent": !k.is_multiple_of(10)}),
            StudyPage::Instructions { .. } => json!({}),
            StudyPage::Questionnaire { items, .. } => answer_all(&items, &mut rng),
            // A study path like any other: the script's answers may miss a pass mark.
            StudyPage::ScreenedOut { .. } => return Ok(Outcome { end: End::ScreenedOut, trials }),
            StudyPage::Trial { hello, .. } | StudyPage::Practice { hello, .. } => {
                trials += usize::from(is_trial);
                let options = SessionOptions {
                    name: hello.name.clone(),
                    template: Some(hello.template.clone()),
                    seat: hello.seat.clone(),
                    ..SessionOptions::default()
                };
                let match_id = play_trial(&browser, &id, step, play, options).await?;
                json!({"match_id": match_id})
            }
        };
        let path = format!("/api/study/participants/{id}/answer");
        let (status, answered) =
            browser.call(Method::POST, &path, Some(json!({"step": step, "answers": answers}))).await?;
        if status != 200 {
            bail!("step {step}'s answer got {status}: {answered}");
        }
        state = serde_json::from_value(answered).context("the answer's state")?;
    }
    bail!("still going after {MAX_STEPS} steps")
}

/// Plays a trial as the page does: joins with the trial's hello, says which match it is
/// in, and returns that match's id once it has ended.
async fn play_trial(
    browser: &Browser,
    id: &str,
    step: usize,
    play: SocketAddr,
    options: SessionOptions,
) -> Result<String> {
    let (welcomed, welcome) = tokio::sync::oneshot::channel();
    let mut welcomed = Some(welcomed);
    let agent = Strategy::Cooperative.agent(&options.name);
    let game = tokio::spawn(bw4t_runner::play_remote_told(play, options, agent, move |w| {
        if let Some(tell) = welcomed.take() {
            let _ = tell.send((w.match_info.name.clone(), w.match_info.id.clone()));
        }
    }));
    let Ok((name, match_id)) = welcome.await else {
        let why = match game.await {
            Ok(Err(e)) => e.to_string(),
            _ => "no welcome".into(),
        };
        bail!("the trial at step {step} could not be joined: {why}");
    };
    let path = format!("/api/study/participants/{id}/trial");
    let started = json!({"step": step, "match": name, "match_id": match_id});
    let (status, answer) = browser.call(Method::POST, &path, Some(started)).await?;
    if status != 200 {
        bail!("the trial's start got {status}: {answer}");
    }
    game.await.context("the trial's player")?.map_err(|e| anyhow!("the trial's match: {e}"))?;
    browser.events(id, step, &[json!({"kind": "match_over"})]).await?;
    Ok(match_id)
}

/// An answer to every item: a Likert point, an option, a short text (an optional text
/// left out now and then), the smallest number taken, every row of a matrix, each drawn
/// from `rng` (an item hidden by its `show_if` is answered too: the study ignores it).
fn answer_all(items: &[QuestionItem], rng: &mut SeededRng) -> Value {
    let mut answers = Map::new();
    for item in items {
        let value = match &item.kind {
            QuestionKind::Likert { scale, .. } => json!(1 + rng.below(u64::from(*scale))),
            QuestionKind::Choice { options } => json!(options[rng.index(options.len())]),
            QuestionKind::Text { .. } if !item.required && rng.below(2) == 0 => continue,
            QuestionKind::Text { .. } => json!("A simulated answer."),
            // The smallest number taken (whole when the item asks for one), else 0.
            QuestionKind::Number { min, max, .. } => json!(min.unwrap_or(max.map_or(0.0, |m| m.min(0.0)))),
            QuestionKind::Matrix { rows, scale, options, .. } => {
                let mut grid = Map::new();
                for row in rows {
                    let value = match (scale, options) {
                        (_, Some(options)) => json!(options[rng.index(options.len())]),
                        (scale, None) => json!(1 + rng.below(u64::from(scale.unwrap_or(7)))),
                    };
                    grid.insert(row.key.clone(), value);
                }
                Value::Object(grid)
            }
        };
        answers.insert(item.id.clone(), value);
    }
    Value::Object(answers)
}

/// A participant's browser: the study's web port and the cookie its arrival set.
struct Browser {
    web: SocketAddr,
    cookie: std::sync::Mutex<Option<String>>,
}

impl Browser {
    /// Reports `events` of the page at `step`.
    async fn events(&self, id: &str, step: usize, events: &[Value]) -> Result<()> {
        let wall_ms = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_millis() as u64);
        let events: Vec<Value> = events
            .iter()
            .map(|e| {
                let mut e = e.clone();
                e["step"] = step.into();
                e["wall_ms"] = wall_ms.into();
                e
            })
            .collect();
        let path = format!("/api/study/participants/{id}/events");
        let (status, answer) = self.call(Method::POST, &path, Some(json!({"events": events}))).await?;
        if status != 200 {
            bail!("events at step {step} got {status}: {answer}");
        }
        Ok(())
    }

    /// One request on a connection of its own (as `fetch` may), JSON both ways; keeps the
    /// cookie a `Set-Cookie` gives.
    async fn call(&self, method: Method, path: &str, body: Option<Value>) -> Result<(u16, Value)> {
        let stream = tokio::net::TcpStream::connect(self.web).await.context("the study's web port")?;
        let (mut sender, connection) = hyper::client::conn::http1::handshake(TokioIo::new(stream)).await?;
        tokio::spawn(connection);
        let mut request = Request::builder()
            .method(method)
            .uri(path)
            .header(header::HOST, self.web.to_string())
            .header(header::CONTENT_TYPE, "application/json");
        let cookie = self.cookie.lock().map_or(None, |c| c.clone());
        if let Some(cookie) = cookie {
            request = request.header(header::COOKIE, cookie);
        }
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let response = sender.send_request(request.body(Full::new(Bytes::from(body)))?).await?;
        let status = response.status().as_u16();
        if let Some(set) = response.headers().get(header::SET_COOKIE).and_then(|v| v.to_str().ok()) {
            if let Ok(mut cookie) = self.cookie.lock() {
                *cookie = set.split(';').next().map(str::to_string);
            }
        }
        let bytes = response.into_body().collect().await?.to_bytes();
        let value = serde_json::from_slice(&bytes).unwrap_or_else(|_| json!(String::from_utf8_lossy(&bytes)));
        Ok((status, value))
    }
}
