//! A grid city as netconvert writes one, for the benchmarks that import or drive one: two lanes
//! each way, every turn a connection with its internal lane.

use std::fmt::Write;

/// Distance between junctions, m.
const BLOCK_M: f64 = 150.0;
/// How far an edge stops short of a junction's centre, m (the junction's area).
const SHORT_M: f64 = 8.0;
/// Lane width, m.
const LANE_M: f64 = 3.2;

/// An edge: its id and the grid places (column, row) of its start and end nodes.
type GridEdge = (String, (isize, isize), (isize, isize));

/// A grid of `side` × `side` junctions as netconvert would write it: under traffic lights
/// (each a two-phase fixed-time program, left turns yielding on green) with `signals`, else
/// priority junctions.
pub fn grid_net(side: usize, signals: bool) -> String {
    let mut xml = String::from("<net version=\"1.20\">\n");
    let node = |i: isize, j: isize| format!("n{i}_{j}");
    let pos = |i: isize, j: isize| (i as f64 * BLOCK_M, j as f64 * BLOCK_M);
    // Edges: between neighbours both ways, plus one in and one out at each end of every row.
    let mut edges: Vec<GridEdge> = Vec::new();
    let n = side as isize;
    for i in 0..n {
        for j in 0..n {
            if i + 1 < n {
                edges.push((format!("h{i}_{j}"), (i, j), (i + 1, j)));
                edges.push((format!("hb{i}_{j}"), (i + 1, j), (i, j)));
            }
            if j + 1 < n {
                edges.push((format!("v{i}_{j}"), (i, j), (i, j + 1)));
                edges.push((format!("vb{i}_{j}"), (i, j + 1), (i, j)));
            }
        }
    }
    for j in 0..n {
        edges.push((format!("in{j}"), (-1, j), (0, j)));
        edges.push((format!("out{j}"), (n - 1, j), (n, j)));
    }
    let lane_shape = |a: (isize, isize), b: (isize, isize), lane: usize| {
        let (p, q) = (pos(a.0, a.1), pos(b.0, b.1));
        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
        let len = dx.hypot(dy);
        let (ux, uy) = (dx / len, dy / len);
        // SUMO's lanes lie to the right of the edge's line.
        let off = (lane as f64 + 0.5) * LANE_M;
        let (rx, ry) = (uy * off, -ux * off);
        (
            (p.0 + ux * SHORT_M + rx, p.1 + uy * SHORT_M + ry),
            (q.0 - ux * SHORT_M + rx, q.1 - uy * SHORT_M + ry),
        )
    };
    for (id, a, b) in &edges {
        let priority = if a.1 == b.1 { 2 } else { 1 };
        let _ = writeln!(
            xml,
            "    <edge id=\"{id}\" from=\"{}\" to=\"{}\" priority=\"{priority}\">",
            node(a.0, a.1),
            node(b.0, b.1)
        );
        for lane in 0..2 {
            let (s, e) = lane_shape(*a, *b, lane);
            let _ = writeln!(
                xml,
                "        <lane id=\"{id}_{lane}\" index=\"{lane}\" speed=\"13.89\" length=\"{:.2}\" \
                 shape=\"{:.2},{:.2} {:.2},{:.2}\"/>",
                BLOCK_M - 2.0 * SHORT_M,
                s.0,
                s.1,
                e.0,
                e.1
            );
        }
        xml.push_str("    </edge>\n");
    }
    // Connections at every junction: from each edge in to each edge out but the one back,
    // straight on from both lanes, a right turn from lane 0, a left turn from lane 1; each with
    // its internal edge, as netconvert writes them.
    for i in 0..n {
        for j in 0..n {
            let here = (i, j);
            let ins: Vec<&GridEdge> = edges.iter().filter(|e| e.2 == here).collect();
            let outs: Vec<&GridEdge> = edges.iter().filter(|e| e.1 == here).collect();
            let kind = if signals { "traffic_light" } else { "priority" };
            let _ = writeln!(
                xml,
                "    <junction id=\"{}\" type=\"{kind}\" x=\"{:.2}\" y=\"{:.2}\"/>",
                node(i, j),
                pos(i, j).0,
                pos(i, j).1
            );
            let mut k = 0;
            // Per connection: whether it comes in along a row (green in the first phase) and
            // whether it turns left (yielding on its green).
            let mut links: Vec<(bool, bool)> = Vec::new();
            for e_in in &ins {
                let din = (e_in.2.0 - e_in.1.0, e_in.2.1 - e_in.1.1);
                for e_out in &outs {
                    let dout = (e_out.2.0 - e_out.1.0, e_out.2.1 - e_out.1.1);
                    if dout == (-din.0, -din.1) {
                        continue;
                    }
                    // Cross product: positive turns left.
                    let turn = din.0 * dout.1 - din.1 * dout.0;
                    let pairs: &[(usize, usize)] = match turn {
                        0 => &[(0, 0), (1, 1)],
                        t if t < 0 => &[(0, 0)],
                        _ => &[(1, 1)],
                    };
                    for &(fl, tl) in pairs {
                        let (_, from_end) = lane_shape(e_in.1, e_in.2, fl);
                        let (to_start, _) = lane_shape(e_out.1, e_out.2, tl);
                        let internal = format!(":{}_{k}", node(i, j));
                        let _ = writeln!(
                            xml,
                            "    <edge id=\"{internal}\" function=\"internal\">\n        <lane \
                             id=\"{internal}_0\" index=\"0\" speed=\"8.00\" length=\"12.00\" \
                             shape=\"{:.2},{:.2} {:.2},{:.2}\"/>\n    </edge>",
                            from_end.0, from_end.1, to_start.0, to_start.1
                        );
                        let control = if signals {
                            format!(" tl=\"{}\" linkIndex=\"{k}\"", node(i, j))
                        } else {
                            String::new()
                        };
                        let state = if signals { "O" } else { "M" };
                        let _ = writeln!(
                            xml,
                            "    <connection from=\"{}\" to=\"{}\" fromLane=\"{fl}\" \
                             toLane=\"{tl}\" via=\"{internal}_0\"{control} dir=\"s\" \
                             state=\"{state}\"/>",
                            e_in.0, e_out.0
                        );
                        links.push((din.1 == 0, turn > 0));
                        k += 1;
                    }
                }
            }
            if signals {
                // Rows green, amber, columns green, amber; a left turn yields on its green.
                let phase = |rows: bool, amber: bool| -> String {
                    links
                        .iter()
                        .map(|&(row, left)| match (row == rows, amber, left) {
                            (false, ..) => 'r',
                            (true, true, _) => 'y',
                            (true, false, true) => 'g',
                            (true, false, false) => 'G',
                        })
                        .collect()
                };
                let _ = writeln!(
                    xml,
                    "    <tlLogic id=\"{}\" type=\"static\" programID=\"0\" offset=\"0\">\n        \
                     <phase duration=\"30\" state=\"{}\"/>\n        <phase duration=\"4\" \
                     state=\"{}\"/>\n        <phase duration=\"30\" state=\"{}\"/>\n        \
                     <phase duration=\"4\" state=\"{}\"/>\n    </tlLogic>",
                    node(i, j),
                    phase(true, false),
                    phase(true, true),
                    phase(false, false),
                    phase(false, true)
                );
            }
        }
    }
    xml.push_str("</net>\n");
    xml
}
