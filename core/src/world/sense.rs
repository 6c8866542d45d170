//! One tick's sensing: range-and-bearing contacts, packet drop and noise, trajectory
//! recording, expiry and the peer refresh, on one thread or on a pool's (`par.rs`).
//!
//! Each robot's sensing reads the poses and its contacts and changes only its own random
//! stream and recorder, so robots are sensed in parallel; what they share is folded afterwards
//! in robot order: the counters (sums), the running mix of every reading (each robot's words
//! in the order it read them) and the chain of completed samples.

use rayon::prelude::*;
use rayon::ThreadPool;

use super::{gaussian_pair, mix_in, Params, Pose, World};
use crate::config::WindowRule;
use crate::data::Recorder;
use crate::rng::Rng;
use crate::types::{Digest, RobotId, SimTime};

/// What one robot's sensing leaves to fold: messages lost, samples completed.
#[derive(Clone, Copy, Default)]
struct Tally {
    dropped: u64,
    completed: u32,
}

/// Robot `i`'s sensing this tick: drops, noise and recording. Every reading's two words go to
/// `word`, in order; `heard` is a buffer.
#[allow(clippy::too_many_arguments)]
fn sense_one(
    p: &Params,
    poses: &[Pose],
    rule: WindowRule,
    now: SimTime,
    i: usize,
    (rng, recorder): (&mut Rng, &mut Recorder),
    neighbours: &[RobotId],
    heard: &mut Vec<RobotId>,
    mut word: impl FnMut(u64),
) -> Tally {
    let sigma = p.rab_noise_std_m;
    let mut dropped = 0;
    heard.clear();
    for &j in neighbours {
        if rng.chance(p.rab_packet_drop) {
            dropped += 1;
        } else {
            heard.push(j);
        }
    }
    // The receiver knows its own pose; the measured offset carries Gaussian noise on each axis
    // (one Box-Muller pair per reading), so the recorded absolute position is the neighbour's
    // true position plus that noise.
    let completed = recorder.observe(&p.recording, rule, now, heard, |j, kept| {
        if !kept {
            return [0.0, 0.0];
        }
        let q = poses[j as usize];
        let (nx, ny) = if sigma > 0.0 {
            gaussian_pair(rng, sigma)
        } else {
            (0.0, 0.0)
        };
        let point = [(q.x + nx) as f32, (q.y + ny) as f32];
        word((u64::from(j) << 32) | i as u64);
        word((u64::from(point[0].to_bits()) << 32) | u64::from(point[1].to_bits()));
        point
    });
    Tally { dropped, completed }
}

impl World {
    /// Range-and-bearing, trajectory recording, expiry and peer refresh at the current tick,
    /// on `pool`'s threads if given (the same bits). On threads, it also leaves each robot's
    /// nearest other robot for the next tick's physics (`Scratch::nearest`) and returns the
    /// overlap count of its contacts' search ([`World::contacts_par`]).
    pub(super) fn sense(&mut self, pool: Option<&ThreadPool>) -> Option<u64> {
        let mut contacts = std::mem::take(&mut self.scratch.contacts);
        let mut heard = std::mem::take(&mut self.scratch.heard);
        let (overlaps, tallies) = match pool {
            None => {
                self.contacts(&mut contacts);
                (None, self.sense_seq(&contacts, &mut heard))
            }
            Some(pool) => {
                // One fork for the whole tick's sensing: a fork from outside the pool costs
                // 12-40 us, a few percent of a 1000-robot tick (docs/PERFORMANCE.md).
                let (overlaps, tallies) = pool.install(|| self.sense_par(&mut contacts));
                self.scratch.nearest_tick = Some(self.tick);
                (Some(overlaps), tallies)
            }
        };
        for (c, t) in contacts.iter().zip(&tallies) {
            self.counters.contact_ticks += c.len() as u64;
            self.counters.messages_dropped += t.dropped;
        }
        if self.tick.is_multiple_of(self.params.peer_refresh_ticks) {
            for (peers, c) in self.peers.iter_mut().zip(&contacts) {
                peers.clone_from(c);
            }
        }
        self.scratch.contacts = contacts;
        self.scratch.heard = heard;
        overlaps
    }

    /// The sensing after the contacts, on the calling thread.
    fn sense_seq(&mut self, contacts: &[Vec<RobotId>], heard: &mut Vec<RobotId>) -> Vec<Tally> {
        let now = self.time();
        let (p, poses, rule) = (&self.params, &self.poses, self.extra.window_rule);
        let mix = &mut self.reading_mix;
        let tallies: Vec<Tally> = (0..poses.len())
            .map(|i| {
                let own = (&mut self.rab_rngs[i], &mut self.recorders[i]);
                sense_one(p, poses, rule, now, i, own, &contacts[i], heard, |w| {
                    *mix = mix_in(*mix, w);
                })
            })
            .collect();
        chain_completed(&mut self.sample_chain, &self.recorders, &tallies);
        for r in &mut self.recorders {
            r.expire(&p.recording, now);
        }
        tallies
    }

    /// The contacts and the sensing on the current rayon pool's threads (call it inside the
    /// pool's `install`), with the overlap count of the contacts' search.
    fn sense_par(&mut self, contacts: &mut Vec<Vec<RobotId>>) -> (u64, Vec<Tally>) {
        let mut later = std::mem::take(&mut self.scratch.later);
        let mut nearest = std::mem::take(&mut self.scratch.nearest);
        let overlaps = self.contacts_par(contacts, &mut later, &mut nearest);
        self.scratch.later = later;
        self.scratch.nearest = nearest;
        let mut words = std::mem::take(&mut self.scratch.words);
        let now = self.time();
        let (p, poses, rule) = (&self.params, &self.poses, self.extra.window_rule);
        words.resize_with(poses.len(), Vec::new);
        let (mix, chain) = (&mut self.reading_mix, &mut self.sample_chain);
        let (rngs, recorders) = (&mut self.rab_rngs, &mut self.recorders);
        // A robot's expiry drops only samples older than `data.expiration_s`, never the ones it
        // completed now, so it may come before the chain reads those.
        let tallies: Vec<Tally> = rngs
            .par_iter_mut()
            .zip(recorders.par_iter_mut())
            .zip(contacts.par_iter())
            .zip(words.par_iter_mut())
            .enumerate()
            .with_min_len(super::par::PIECE)
            .map_init(Vec::new, |heard, (i, (((rng, rec), nb), words))| {
                words.clear();
                let own = (rng, &mut *rec);
                let tally = sense_one(p, poses, rule, now, i, own, nb, heard, |w| {
                    words.push(w);
                });
                rec.expire(&p.recording, now);
                tally
            })
            .collect();
        // The two running digests are independent folds, each in robot order: one thread each.
        let recorders = &*recorders;
        rayon::join(
            || {
                for w in words.iter().flatten() {
                    *mix = mix_in(*mix, *w);
                }
            },
            || chain_completed(chain, recorders, &tallies),
        );
        self.scratch.words = words;
        (overlaps, tallies)
    }
}

/// Folds into `chain`, in robot order, the samples each robot completed this tick (the last
/// `completed` of its recorder).
fn chain_completed(chain: &mut Digest, recorders: &[Recorder], tallies: &[Tally]) {
    for (i, (r, t)) in recorders.iter().zip(tallies).enumerate() {
        if t.completed > 0 {
            let samples = r.samples();
            for s in samples.range(samples.len() - t.completed as usize..) {
                *chain = super::chain_sample(chain, i as RobotId, s);
            }
        }
    }
}
