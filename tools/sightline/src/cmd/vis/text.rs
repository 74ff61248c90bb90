//! The text reports of `sightline vis` (`--json` prints the library's report records instead).

use sightline_compiler::dropin::{PackReport, Q2Report, Q3Report, QuakeReport};
use sightline_compiler::vis::VisStats;

/// The line of a merge of shard files (`sightline vis merge`), or nothing.
pub(super) fn merged(v: Option<&VisStats>) -> String {
    let Some(m) = v.and_then(|v| v.merged.as_ref()) else { return String::new() };
    let mut line = format!("merged {} shards in {} waves", m.shards, m.waves);
    if !m.missing.is_empty() {
        line += &format!(
            "; PARTIAL: {} shard files missing ({}), their {} portals keep their base vis, which alone gives {} visible leaf pairs",
            m.missing.len(),
            m.missing.join(", "),
            m.missing_portals,
            m.pairs_from_missing
        );
    }
    line + "\n"
}

/// The report of a Quake 1 or Half-Life `.bsp`, or of a portal file.
pub(super) fn quake(r: &QuakeReport) -> String {
    let v = &r.vis;
    let mut extra = String::new();
    if let Some(d) = r.farplane {
        extra += &format!("far plane {d}: {} cluster pairs hidden\n", r.farplane_hidden_pairs);
    }
    if !r.ambient_off.is_empty() {
        extra += &format!("ambient sounds off: {}\n", r.ambient_off.join(", "));
    }
    if let Some(t) = &r.texinfo_json {
        extra += &format!("{t}: {} texinfos make no ambient sound\n", r.noambient_texinfos);
    }
    if let Some(s) = &r.portals_rebuilt {
        extra += &crate::cmd::portals::stats_line(s);
    }
    let mode = if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
    format!(
        "{input} ({fmt}): {leaves} leaves, {clusters} clusters, {portals} portals{dropped}\n\
         vis {mode}, {threads} threads\n\
         visible leaves: average {avg:.1} ({pct:.1} %), median {med}, max {max}; base vis average {might:.1}\n\
         portal chains visited: {chains}{resumed}\n\
         {extra}\
         compressed PVS: {bytes} bytes -> {output}\n\
         time: read {read:.3} s, base {base:.3} s, flow {flow:.3} s{estimated}, rows {rows:.3} s, write {write:.3} s, total {total:.3} s\n",
        input = r.input,
        fmt = r.prt_format,
        leaves = v.leaves,
        clusters = v.clusters,
        portals = v.portals,
        dropped = if v.dropped_portals > 0 {
            format!(" ({} without area dropped)", v.dropped_portals)
        } else {
            String::new()
        },
        threads = v.threads,
        avg = v.avg_visible,
        pct = v.percent_visible,
        med = v.median_visible,
        max = v.max_visible,
        might = v.avg_mightsee,
        chains = v.chains,
        resumed = if v.resumed_portals > 0 {
            format!(" ({} portals resumed from the state file)", v.resumed_portals)
        } else {
            String::new()
        },
        bytes = r.compressed_bytes,
        output = r.output,
        read = r.read_seconds,
        base = v.base_seconds,
        flow = v.flow_seconds,
        estimated = if v.flow_estimate_work > 0 {
            format!(" (estimated {:.3} s)", v.flow_estimate_seconds)
        } else {
            String::new()
        },
        rows = v.rows_seconds,
        write = r.write_seconds,
        total = r.total_seconds,
    )
}

/// The report of a Quake 2 `.bsp`.
pub(super) fn quake2(r: &Q2Report) -> String {
    let mut s = format!("{} (Quake 2, {}): {} clusters\n", r.input, r.mode, r.clusters);
    if let Some(v) = &r.vis {
        let mode =
            if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
        s += &format!(
            "vis {mode}, {} threads, {} portals; base {:.3} s, flow {:.3} s\n",
            v.threads, v.portals, v.base_seconds, v.flow_seconds
        );
    }
    if let (Some(d), Some(hidden)) = (r.farplane, r.farplane_hidden_pairs) {
        s += &format!("far plane {d}: {hidden} cluster pairs hidden\n");
    }
    s += &format!("PVS pairs {}, PHS pairs {}\n", r.pvs_pairs, r.phs_pairs);
    if let Some(f) = &r.phs_repair {
        s += &format!(
            "PHS repaired: {} of {} rows changed, {} bits added, {} removed; PVS rows kept byte for byte\n",
            f.rows_fixed, f.clusters, f.bits_added, f.bits_removed
        );
    }
    s += &format!(
        "visibility lump: {} bytes -> {}\ntime: total {:.3} s\n",
        r.visibility_bytes, r.input, r.total_seconds
    );
    s
}

/// The report of a Quake 3 `.bsp`.
pub(super) fn quake3(r: &Q3Report) -> String {
    let v = &r.vis;
    let mode = if v.fast { "fast (base vis only)".to_string() } else { format!("full, level {}", v.level) };
    format!(
        "{} (Quake 3, {} portals from {}): {} clusters\n\
         vis {mode}, {} threads; base {:.3} s, flow {:.3} s\n\
         PVS pairs {} (average {:.1} clusters)\n\
         visibility lump: {} bytes -> {}\ntime: total {:.3} s\n",
        r.input,
        r.prt_format,
        r.prt,
        r.clusters,
        v.threads,
        v.base_seconds,
        v.flow_seconds,
        r.pvs_pairs,
        r.pvs_pairs as f64 / r.clusters.max(1) as f64,
        r.visibility_bytes,
        r.input,
        r.total_seconds
    )
}

/// The report of a folder made into one pack.
pub(super) fn pack(r: &PackReport) -> String {
    let mut s = format!("{}: {} maps", r.input, r.maps.len());
    if let Some(out) = &r.output {
        s += &format!(" -> {out}");
    }
    s += "\n";
    for m in &r.maps {
        s += &format!(
            "  {}: {} vis leaves, {} portals, average {:.1} visible, visdata {} bytes, {:.3} s\n",
            m.map, m.vis_leaves, m.portals, m.avg_visible, m.visdata_bytes, m.seconds
        );
    }
    if !r.skipped.is_empty() {
        s += &format!("skipped {} (not in the pack):\n", r.skipped.len());
        for k in &r.skipped {
            s += &format!("  {}: {}\n", k.file, k.reason);
        }
    }
    s + &format!("time: total {:.3} s\n", r.total_seconds)
}
