//! Admission: `hello` for each role with its own token, seats (at most `robots` players,
//! reserved names, reconnects by session), robot names and the `welcome`.

use bw4t_protocol::{ErrorCode, Hello, MatchInfo, Mode, Role, ServerMessage, VERSION, Welcome};
use bw4t_sim::{JoinError, RobotId};

use super::{ConnId, ConnRole, Delivery, MatchHost, Player, Sight};
use crate::{HostConfig, HostError};

/// Refuses a configuration in which two roles share a token, since one role's secret
/// would then open the other's.
pub(super) fn check_tokens_differ(config: &HostConfig) -> Result<(), HostError> {
    let tokens = [
        ("player", &config.token),
        ("spectator", &config.spectator_token),
        ("operator", &config.operator_token),
    ];
    for (i, (a, first)) in tokens.iter().enumerate() {
        for (b, second) in &tokens[i + 1..] {
            if first.is_some() && first == second {
                return Err(HostError::SameToken(a, b));
            }
        }
    }
    Ok(())
}

impl MatchHost {
    pub(super) fn on_hello(&mut self, conn: ConnId, role: ConnRole, hello: &Hello) {
        if role != ConnRole::New {
            return self.error(
                conn,
                ErrorCode::AlreadyJoined,
                "this connection has already said hello",
                false,
            );
        }
        if hello.protocol != bw4t_protocol::PROTOCOL {
            let message = format!("unknown protocol '{}' (this server speaks 'bw4t')", hello.protocol);
            return self.error(conn, ErrorCode::BadProtocol, &message, true);
        }
        if !hello.versions.contains(&VERSION) {
            let message = format!("no common protocol version (this server speaks {VERSION})");
            return self.error(conn, ErrorCode::UnsupportedVersion, &message, true);
        }
        if let Err(message) = self.check_token(hello) {
            return self.error(conn, ErrorCode::BadToken, message, true);
        }
        if let Some(c) = self.conns.get_mut(&conn) {
            c.lobby = hello.match_name.is_some() || hello.template.is_some();
        }
        let sight = match hello.role {
            Role::Agent => None,
            Role::Spectator if !self.config.spectators_see_private => Some(Sight::Public),
            Role::Spectator | Role::Operator => Some(Sight::Everything),
        };
        if let Some(sight) = sight {
            if let Some(c) = self.conns.get_mut(&conn) {
                c.role = ConnRole::Watcher(sight);
            }
            tracing::debug!(target: "bw4t::match", r#match = %self.config.name, conn, role = ?hello.role, "watcher joined");
            self.welcome(conn, None, false, Some(sight == Sight::Everything));
            return self.send_frames(true);
        }
        let every_tick = self.config.every_tick || hello.every_tick;
        let robot = match &hello.session {
            Some(session) => {
                let found = self.players.iter().find(|(_, p)| &p.session == session).map(|(id, _)| *id);
                let Some(id) = found else {
                    return self.error(conn, ErrorCode::BadSession, "unknown or expired session", true);
                };
                if let Some(old) = self.players.get(&id).and_then(|p| p.conn) {
                    self.error(
                        old,
                        ErrorCode::Replaced,
                        "the session was taken up by a new connection",
                        true,
                    );
                }
                id
            }
            None => {
                let seat = self
                    .players
                    .iter()
                    .find(|(_, p)| {
                        p.reserved && p.conn.is_none() && Some(p.name.as_str()) == hello.name.as_deref()
                    })
                    .map(|(id, _)| *id);
                match seat {
                    Some(id) => id,
                    None => match self.join(hello.name.as_deref()) {
                        Ok(id) => id,
                        Err((code, message)) => return self.error(conn, code, &message, true),
                    },
                }
            }
        };
        if let Some(player) = self.players.get_mut(&robot) {
            player.conn = Some(conn);
            player.connected_ever = true;
            player.late_in_row = 0;
            player.dropped_at = None;
            player.absences.ended(self.game.tick());
            player.every_tick = every_tick;
            // A player taking its robot back with `words` keeps what the robot remembers.
            player.knowledge = match (hello.words, player.knowledge.take()) {
                (false, _) => None,
                (true, kept) => Some(kept.unwrap_or_default()),
            };
            player.full_since = None;
        }
        if let Some(c) = self.conns.get_mut(&conn) {
            c.role = ConnRole::Agent(robot);
        }
        let name = self.players.get(&robot).map(|p| p.name.as_str()).unwrap_or_default();
        let how = if hello.session.is_some() { "player reconnected" } else { "player joined" };
        tracing::info!(target: "bw4t::match", r#match = %self.config.name, player = %name, robot = robot.0, conn, "{how}");
        self.welcome(conn, Some(robot), every_tick, None);
        self.send_percepts(robot, Delivery::Snapshot);
        self.note_presence();
    }

    /// Checks the credential of the role `hello` asks for; the error says what is missing.
    fn check_token(&self, hello: &Hello) -> Result<(), &'static str> {
        let presents = |secret: &Option<String>| matches!((secret, &hello.token), (Some(s), Some(t)) if same_secret(t, s));
        let config = &self.config;
        match hello.role {
            Role::Agent if config.token.is_none() || presents(&config.token) => Ok(()),
            Role::Agent => Err("wrong or missing player token"),
            // A local match (no player or spectator token) is open to watch.
            Role::Spectator if config.token.is_none() && config.spectator_token.is_none() => Ok(()),
            Role::Spectator if presents(&config.spectator_token) || presents(&config.operator_token) => {
                Ok(())
            }
            Role::Spectator => Err("watching this match needs the spectator token"),
            Role::Operator if presents(&config.operator_token) => Ok(()),
            Role::Operator if config.operator_token.is_none() => Err("this server has no operator token"),
            Role::Operator => Err("wrong or missing operator token"),
        }
    }

    pub(super) fn join(&mut self, name: Option<&str>) -> Result<RobotId, (ErrorCode, String)> {
        let name = match name {
            Some(n) => n.to_string(),
            None => (1..)
                .map(|i| format!("Player{i}"))
                .find(|n| self.players.values().all(|p| &p.name != n))
                .unwrap_or_default(),
        };
        let refusal = |e: JoinError| {
            let code = match e {
                JoinError::InvalidName(_) => ErrorCode::InvalidName,
                JoinError::NameTaken(_) => ErrorCode::NameTaken,
                JoinError::Full(_) => ErrorCode::MatchFull,
            };
            (code, e.to_string())
        };
        self.game.check_name(&name).map_err(refusal)?;
        // Every player in the match holds a seat: connected, reserved, or dropped and
        // within its grace period.
        let seats = self.played.robots;
        if self.players.len() >= seats {
            return Err((ErrorCode::MatchFull, format!("the match is full: it admits {seats} players")));
        }
        let id = self.game.join_logged(&name, &mut self.recorder).map_err(refusal)?;
        // The id may have been another robot's: its figures belong to that one.
        self.late.remove(&id);
        self.gone.remove(&id);
        self.usage.remove(&id);
        self.sessions += 1;
        let session = format!("{:016x}{:08x}", session_entropy(), self.sessions);
        self.players.insert(id, Player::new(name, session));
        Ok(id)
    }

    fn welcome(&mut self, conn: ConnId, robot: Option<RobotId>, every_tick: bool, private: Option<bool>) {
        let player = robot.and_then(|r| self.players.get(&r));
        let welcome = Welcome {
            version: VERSION,
            name: player.map(|p| p.name.clone()),
            robot: robot.map(|r| r.0),
            session: player.map(|p| p.session.clone()),
            private_messages: private,
            match_info: MatchInfo {
                name: self.config.name.clone(),
                id: self.config.id.clone(),
                template: self.config.template.clone(),
                map: self.game.map().name().to_string(),
                seed: self.played.seed,
                mode: self.config.mode,
                tick_hz: self.played.tick_hz,
                deadline_ms: (self.config.mode == Mode::Lockstep)
                    .then(|| self.config.deadline.map_or(0, |d| d.as_millis() as u64)),
                players_needed: self.played.robots,
                max_ticks: self.played.max_ticks,
                every_tick,
                language: bw4t_protocol::MessagePolicy {
                    kinds: Some(self.config.language.allowed_kinds()),
                    free_text: self.config.language.free_text,
                },
            },
        };
        self.send(conn, &ServerMessage::Welcome(welcome));
        if self.held {
            self.tell_pause(Some(conn));
        }
        // Whoever arrives at a waiting match is told who is there (and the others that
        // someone came).
        self.lobby_changed |= matches!(self.phase, super::Phase::Waiting { .. });
    }
}

/// Whether `given` is `secret`, in a time that does not depend on where they differ.
pub fn same_secret(given: &str, secret: &str) -> bool {
    let differences = given.bytes().zip(secret.bytes()).fold(0u8, |acc, (a, b)| acc | (a ^ b));
    given.len() == secret.len() && differences == 0
}

/// Unpredictable bits for session tokens, from the standard library's per-process keys.
fn session_entropy() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u64(0);
    h.finish()
}
