//! One view of a compiled map over every family Sightline reads: Quake (BSP29, BSP2, BSP2-RMQ),
//! Half-Life (BSP30), Quake 2 (`IBSP` 38) and Quake 3 (`IBSP` 46/47).
//!
//! [`CompiledMap::read`] looks at the first bytes once ([`Game::sniff`]) and parses the file with
//! its family's reader; the view then answers what every user of a compiled map asks: which game
//! it is, how many vis clusters it has (Quake 1 and Half-Life: vis leaves; Quake 2 and 3: the
//! leaves' clusters), whether its lumps let visibility be written back
//! ([`CompiledMap::check_vis_layout`]), and the file as a [`Level`] ([`CompiledMap::to_level`]).
//! Writing visibility back differs by family and lives with the family's reader
//! ([`super::write_vis_rows`], [`super::q2::write_with_visibility`],
//! [`super::q3::write_with_visibility`]); the compiler's drop-in vis chooses among them.

use super::bounds::{self, BoundsRepair};
use super::{Bsp, BspError, BspVersion, lumps, q2, q3};
use crate::level::Level;

/// The game a compiled map is for, known from its first 8 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Game {
    /// Quake 1 (BSP29, BSP2, BSP2-RMQ) or Half-Life (BSP30): one PVS row per vis leaf.
    Quake(BspVersion),
    /// Quake 2 (`IBSP` 38): cluster rows, PVS and PHS in one lump.
    Quake2,
    /// Quake 3 (`IBSP` 46 or 47): uncompressed cluster rows.
    Quake3,
}

impl Game {
    /// The game of a file starting with `head` (at least its first 8 bytes), or `None` when it
    /// is no compiled map Sightline reads. Any other `IBSP` version is taken as Quake 2, whose
    /// reader then names the version it expected.
    pub fn sniff(head: &[u8]) -> Option<Self> {
        if q3::is_q3(head) {
            return Some(Self::Quake3);
        }
        if lumps::is_ibsp(head) {
            return Some(Self::Quake2);
        }
        let magic = head.get(..4)?;
        BspVersion::ALL.into_iter().find(|v| v.magic() == magic).map(Self::Quake)
    }

    /// How reports name the game: `Quake`, `Half-Life`, `Quake 2`, `Quake 3`. The one place a
    /// game is named (errors about a file of the wrong game say it through this).
    pub fn name(self) -> &'static str {
        match self {
            Self::Quake(v) => v.game(),
            Self::Quake2 => "Quake 2",
            Self::Quake3 => "Quake 3",
        }
    }
}

/// A compiled map parsed by its family's reader.
#[derive(Debug, Clone)]
pub enum Parsed {
    /// Quake 1 or Half-Life.
    Quake(Bsp),
    /// Quake 2.
    Quake2(q2::Q2Bsp),
    /// Quake 3.
    Quake3(q3::Q3Bsp),
}

/// A compiled map: its bytes and their parse (see the module docs).
#[derive(Debug, Clone)]
pub struct CompiledMap {
    bytes: Vec<u8>,
    parsed: Parsed,
}

impl CompiledMap {
    /// Parses `bytes` with the reader of the game they start like; a file of no known game is
    /// read as Quake 1, whose reader names the magic it found.
    pub fn read(bytes: Vec<u8>) -> Result<Self, BspError> {
        let parsed = match Game::sniff(&bytes) {
            Some(Game::Quake3) => Parsed::Quake3(q3::read(&bytes)?),
            Some(Game::Quake2) => Parsed::Quake2(q2::read(&bytes)?),
            Some(Game::Quake(_)) | None => Parsed::Quake(super::read(&bytes)?),
        };
        Ok(Self { bytes, parsed })
    }

    /// The file's bytes, as read.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// The parse.
    pub fn parsed(&self) -> &Parsed {
        &self.parsed
    }

    /// The game.
    pub fn game(&self) -> Game {
        match &self.parsed {
            Parsed::Quake(b) => Game::Quake(b.version),
            Parsed::Quake2(_) => Game::Quake2,
            Parsed::Quake3(_) => Game::Quake3,
        }
    }

    /// The rows vis computes: vis leaves of the world model (Quake 1, Half-Life) or leaf
    /// clusters (Quake 2 and 3).
    pub fn clusters(&self) -> usize {
        match &self.parsed {
            Parsed::Quake(b) => b.models.first().map_or(0, |m| m.visleafs as usize),
            Parsed::Quake2(f) => f.leaf_cluster_count(),
            Parsed::Quake3(f) => f.leaf_cluster_count(),
        }
    }

    /// Whether the file's lumps let its visibility be replaced, every other byte kept: refuses
    /// overlapping lumps (with both byte ranges), before any vis work.
    pub fn check_vis_layout(&self) -> Result<(), BspError> {
        match &self.parsed {
            Parsed::Quake(b) => super::check_vis_layout(&b.lumps),
            Parsed::Quake2(f) => q2::check_vis_layout(&f.lumps),
            Parsed::Quake3(f) => q3::check_vis_layout(&f.lumps),
        }
    }

    /// The map as a [`Level`]: Quake 1 and Half-Life one cluster per vis leaf
    /// ([`super::to_level`]); Quake 2 the file's clusters and texinfo draw data
    /// ([`q2::to_level`]); Quake 3 its clusters, opaque leaves solid ([`q3::to_level`]). Bounds the
    /// file stores unusable are replaced ([`bounds`]).
    pub fn to_level(&self) -> Level {
        self.to_level_with_repairs().0
    }

    /// [`CompiledMap::to_level`], with the repairs of stored bounds that something uses: what a
    /// caller of the level should warn about ([`BoundsRepair`]).
    pub fn to_level_with_repairs(&self) -> (Level, Vec<BoundsRepair>) {
        let mut level = match &self.parsed {
            Parsed::Quake(b) => super::convert::level_as_stored(b),
            Parsed::Quake2(f) => q2::level_as_stored(f),
            Parsed::Quake3(f) => q3::level_as_stored(f),
        };
        let repairs = bounds::repair(&mut level);
        (level, repairs)
    }
}
