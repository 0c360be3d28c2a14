(function () {
  "use strict";
  var S = KFX.summary;
  if (window.location.hash === "#model") document.body.classList.add("model-only");
  function el(id) { return document.getElementById(id); }
  function text(s) { return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;"); }
  function fixed(v, digits) { return (v === undefined || v === null) ? "—" : Number(v).toFixed(digits); }

  // ---- Summary ----
  document.title = "kfx report: " + S.input;
  el("title").textContent = "kfx run: " + S.input;
  el("subtitle").textContent = "kfx " + S.kfx_version + " · " + S.backend + " (" + S.device + ")";
  if (S.interrupted) {  // stopped by Ctrl-C: everything below covers the frames done only
    el("subtitle").insertAdjacentHTML("beforeend", ' · <span class="interrupted">interrupted (Ctrl-C) after ' +
      S.frames + (S.frames_in_input ? " of " + S.frames_in_input : "") + " frames</span>");
  }
  var rows = [
    ["Input", S.input_description || S.input],
    ["Preset", S.preset],
    ["Settings changed from the preset", S.settings_changed.length ? S.settings_changed.join(", ") : "none"],
    ["Settings from the input", S.settings_from_input.length ? S.settings_from_input.join(", ") : "none"],
    ["Frames", S.frames + (S.interrupted ? " (interrupted by Ctrl-C" + (S.frames_in_input ? " of " + S.frames_in_input : "") +
                                   " frames; the outputs cover the frames done)" : "")],
    ["Tracked", S.tracked + " (" + fixed(100 * S.tracked / Math.max(1, S.frames), 1) + " %)"],
    ["Integrated", S.integrated],
    ["Tracking lost", S.lost + " frame(s)" + (KFX.lost_frames.length ? " (marked red below)" : "")],
    // The terminal's rounding (stats.json keeps every digit).
    ["Frames/s (1 / mean computation time)", S.frames_per_second_text !== undefined ? S.frames_per_second_text : fixed(S.frames_per_second, 1)]
  ];
  if (S.ate_rmse_m !== undefined) {
    rows.push(["ATE RMSE (aligned, TUM-style" + (S.ate_flip_y ? ", estimate y flipped" : "") + ")",
               fixed(100 * S.ate_rmse_m, 2) + " cm"]);
    if (S.rpe_translation_rmse_m !== undefined) {
      rows.push(["RPE RMSE (" + S.rpe_delta_frames + " frame)", fixed(100 * S.rpe_translation_rmse_m, 2) + " cm, " +
                 fixed(S.rpe_rotation_rmse_deg, 3) + "°"]);
    }
    if (S.diverged_frames !== undefined) {
      rows.push(["Diverged (aligned error over " + fixed(100 * S.divergence_bound_m, 0) + " cm)",
                 S.diverged_frames ? S.diverged_frames + " frame(s), the first " + S.first_diverged_frame +
                   (S.departure_frame !== null && S.departure_frame !== undefined ? ", departure at frame " + S.departure_frame : "")
                 : "none"]);
    }
  } else {
    rows.push(["ATE", S.ate_error ? "not computed: " + S.ate_error : "no ground truth"]);
  }
  // The block map's memory (stats.json "map_*"), as the progress line gives it.
  if (S.map_blocks !== undefined) {
    var mib = function (b) { return fixed(b / 1048576, 1) + " MiB"; };
    var map = S.map_blocks + " blocks, " + mib(S.map_bytes) + " of map_budget_mb " +
              S.config.volume.map_budget_mb;
    if (S.map_blocks_swapped > 0) {
      map += "; " + S.map_blocks_swapped + " blocks swapped to host memory (" +
             mib(S.map_swapped_bytes) + ", " + S.map_swap_passes + " passes)";
    }
    map += "; " + (S.map_frames_short_of_blocks > 0
                   ? S.map_frames_short_of_blocks + " frame(s) short of blocks, from frame " +
                     S.map_first_frame_short_of_blocks
                   : "no frame short of blocks");
    rows.push(["Map (volume=blocks)", map]);
  }
  // The colour field: what is in use and what the backend set aside (stats.json "colour").
  if (S.colour && S.colour.fused && S.colour.memory_bytes !== undefined) {
    var colourMib = function (b) { return fixed(b / 1048576, 1) + " MiB"; };
    rows.push(["Colour field (with its frame buffers)", colourMib(S.colour.memory_bytes) + " in use" +
               (S.colour.memory_bytes_reserved !== undefined ? ", " + colourMib(S.colour.memory_bytes_reserved) + " reserved" : "")]);
  }
    // Energy per frame (stats.json "energy"): each domain's figures, or why it was not measured.
  ["gpu", "cpu"].forEach(function (domain) {
    var e = (S.energy || {})[domain];
    if (!e) return;
    var label = "Energy, " + domain.toUpperCase();
    if (!e.available) { rows.push([label, e.reason || e.method]); return; }
    var value = fixed(1000 * e.joules_per_frame, 3) + " mJ/frame, " + fixed(e.mean_watts, 1) +
                " W mean (" + e.method + ")";
    if (e.above_idle_joules_per_frame !== undefined) {
      value += "; " + fixed(1000 * e.above_idle_joules_per_frame, 3) + " mJ/frame above idle";
    }
    rows.push([label, value]);
  });
  el("summary").innerHTML = rows.map(function (r) {
    return "<tr><td>" + text(r[0]) + "</td><td>" + text(r[1]) + "</td></tr>";
  }).join("");
  var settings = [];
  Object.keys(S.config).forEach(function (section) {
    Object.keys(S.config[section]).forEach(function (key) {
      settings.push("<tr><td>" + text(section + "." + key) + "</td><td>" + text(S.config[section][key]) + "</td></tr>");
    });
  });
  el("settings").innerHTML = settings.join("");

  // ---- Warnings: every stretch of frames with a warning cause (stats.json's warning_stretches) ----
  var stretches = KFX.warning_stretches || [];
  // Every warning line as the terminal said it (stats.json's warnings), with its frame.
  var lines = KFX.warning_lines || [];
  var warningsHtml = "";
  if (stretches.length) {
    warningsHtml += '<table class="warnings"><tr><th>cause</th><th>frames</th><th>frames with it</th></tr>' +
      stretches.map(function (w) {
        var range = w.first_frame === w.last_frame ? String(w.first_frame) : w.first_frame + "–" + w.last_frame;
        return "<tr><td>" + text(w.description || w.cause) + "</td><td>" + text(range) + "</td><td>" + text(w.frames) + "</td></tr>";
      }).join("") + "</table>";
  }
  if (lines.length) {
    warningsHtml += '<h3>As said during the run</h3><table class="warning-lines"><tr><th>frame</th><th>warning</th></tr>' +
      lines.map(function (w) {
        return "<tr><td>" + text(w.frame === null ? "whole run" : w.frame) + "</td><td>" + text(w.text) + "</td></tr>";
      }).join("") + "</table>";
  }
  el("warnings").innerHTML = warningsHtml || '<div class="note">No warnings: no frame was lost, poorly constrained, diverged or ' +
    "out of the volume, no depth looked implausible, and the input and settings needed no remark.</div>";

  // ---- Tracking state: good / poor / lost per frame, as counts and stretches (stats.json's
  // tracking_states; absent from runs written before it existed) ----
  var T = KFX.tracking_states;
  if (!T) {
    el("tracking-states").innerHTML = '<div class="note">This run was written before kfx judged each frame\'s tracking state.</div>';
  } else {
    var timeline = '<div class="note">good ' + text(T.good) + ", poor " + text(T.poor) + ", lost " + text(T.lost) +
      " frame(s). Poor: the view leaves a direction nearly free, so the pose can slide while every frame passes the accept test; lost: the accept test failed.</div>";
    if ((T.stretches || []).length) {
      timeline += '<table class="tracking-states"><tr><th>state</th><th>frames</th><th>frames in it</th></tr>' +
        T.stretches.map(function (t) {
          var range = t.first_frame === t.last_frame ? String(t.first_frame) : t.first_frame + "–" + t.last_frame;
          return "<tr><td>" + text(t.state) + "</td><td>" + text(range) + "</td><td>" + text(t.frames) + "</td></tr>";
        }).join("") + "</table>";
    }
    el("tracking-states").innerHTML = timeline;
  }

  // ---- Lost frames: tracking ran and failed (stats.json's lost_frames) ----
  var L = KFX.log;
  var lost = KFX.lost_frames;

  // ---- SVG line plots ----
  var W = 520, H = 330, M0 = { l: 58, r: 14, t: 30, b: 44 };
  function niceTicks(lo, hi, count) {  // steps of 1, 2 or 5 × 10^k, about `count` of them
    var raw = (hi - lo) / count, magnitude = Math.pow(10, Math.floor(Math.log10(raw)));
    var step = [1, 2, 5, 10].map(function (m) { return m * magnitude; }).filter(function (s) { return s >= raw; })[0];
    var ticks = [];
    for (var v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * (hi - lo); v += step) ticks.push(Math.abs(v) < 1e-12 * step ? 0 : v);
    return ticks;
  }
  // opts: title, xlabel, ylabel, series [{name, x[], y[], color, dots}], vlines [x], equal, flipY
  function plot(container, opts) {
    var xs = [], ys = [];
    opts.series.forEach(function (s) { xs = xs.concat(s.x); ys = ys.concat(s.y); });
    if (!xs.length) return;
    var x0 = Math.min.apply(null, xs), x1 = Math.max.apply(null, xs);
    var y0 = Math.min.apply(null, ys), y1 = Math.max.apply(null, ys);
    if (opts.zeroY) y0 = Math.min(0, y0);
    if (x1 - x0 < 1e-9) { x0 -= 0.5; x1 += 0.5; }
    if (y1 - y0 < 1e-9) { y0 -= 0.5; y1 += 0.5; }
    // The legend sits in rows above the plot area, never over the lines.
    var legend = [], lx = M0.l, ly = 0;
    opts.series.forEach(function (s) {
      var width = 7 * s.name.length + 16;
      if (lx + width > W - M0.r && lx > M0.l) { lx = M0.l; ++ly; }
      legend.push({ name: s.name, color: s.color, x: lx, row: ly });
      lx += width;
    });
    var M = { l: M0.l, r: M0.r, t: M0.t + 14 * (ly + 1), b: M0.b };
    var pw = W - M.l - M.r, ph = H - M.t - M.b;
    if (opts.equal) {  // same metres per pixel on both axes
      var scale = Math.max((x1 - x0) / pw, (y1 - y0) / ph) * 1.08;
      var cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
      x0 = cx - scale * pw / 2; x1 = cx + scale * pw / 2; y0 = cy - scale * ph / 2; y1 = cy + scale * ph / 2;
    } else {
      var pad = 0.04 * (y1 - y0); y1 += pad; if (!opts.zeroY) y0 -= pad;
    }
    function X(v) { return M.l + (v - x0) / (x1 - x0) * pw; }
    function Y(v) { var u = (v - y0) / (y1 - y0); return M.t + (opts.flipY ? u : 1 - u) * ph; }
    var svg = ['<svg class="plot" xmlns="http://www.w3.org/2000/svg" width="' + W + '" height="' + H + '">'];
    svg.push('<text x="' + (W / 2) + '" y="18" text-anchor="middle" font-size="14">' + text(opts.title) + '</text>');
    niceTicks(x0, x1, 6).forEach(function (v) {
      svg.push('<line x1="' + X(v) + '" x2="' + X(v) + '" y1="' + M.t + '" y2="' + (M.t + ph) + '" stroke="#eee"/>');
      svg.push('<text x="' + X(v) + '" y="' + (M.t + ph + 15) + '" text-anchor="middle" font-size="11">' + +v.toPrecision(4) + '</text>');
    });
    niceTicks(y0, y1, 6).forEach(function (v) {
      svg.push('<line x1="' + M.l + '" x2="' + (M.l + pw) + '" y1="' + Y(v) + '" y2="' + Y(v) + '" stroke="#eee"/>');
      svg.push('<text x="' + (M.l - 5) + '" y="' + (Y(v) + 4) + '" text-anchor="end" font-size="11">' + +v.toPrecision(4) + '</text>');
    });
    svg.push('<rect x="' + M.l + '" y="' + M.t + '" width="' + pw + '" height="' + ph + '" fill="none" stroke="#999"/>');
    svg.push('<text x="' + (M.l + pw / 2) + '" y="' + (H - 6) + '" text-anchor="middle" font-size="12">' + text(opts.xlabel) + '</text>');
    svg.push('<text transform="translate(14,' + (M.t + ph / 2) + ') rotate(-90)" text-anchor="middle" font-size="12">' + text(opts.ylabel) + '</text>');
    (opts.vlines || []).forEach(function (v) {
      svg.push('<line class="lost" x1="' + X(v) + '" x2="' + X(v) + '" y1="' + M.t + '" y2="' + (M.t + ph) + '" stroke="#e33" stroke-opacity="0.35"/>');
    });
    opts.series.forEach(function (s, k) {
      var pts = s.x.map(function (v, j) { return X(v).toFixed(1) + "," + Y(s.y[j]).toFixed(1); });
      if (s.dots) {
        pts.forEach(function (p) { var q = p.split(","); svg.push('<circle cx="' + q[0] + '" cy="' + q[1] + '" r="3" fill="' + s.color + '"/>'); });
      } else {
        svg.push('<polyline class="series" fill="none" stroke-width="1.5" stroke="' + s.color + '" points="' + pts.join(" ") + '"/>');
      }
      var g = legend[k];
      svg.push('<text class="legend" x="' + g.x + '" y="' + (M0.t + 8 + 14 * g.row) + '" font-size="11" fill="' + s.color + '">' + text(s.name) + '</text>');
    });
    svg.push('</svg>');
    container.insertAdjacentHTML("beforeend", svg.join(""));
  }
  function column(points, axis) { return points.map(function (p) { return p[axis]; }); }

  // ---- Trajectory: two views, against ground truth when present, lost frames as red dots ----
  var T = KFX.trajectory;
  el("trajectory-note").textContent = T.note + (lost.length ? "; red: frames whose tracking failed (" + lost.length + ")" : "");
  var volume = T.frame === "volume";
  // The plan view: the two axes along which the camera travelled farthest (a floor plan for a
  // walk through rooms, whatever frame the poses are in); the side view: the farther of them
  // against the third. In the volume frame y points down, so a plot with y upright flips it.
  var pathForExtent = T.gt && T.gt.length ? T.gt : T.est;
  var extent = [0, 1, 2].map(function (a) {
    var v = column(pathForExtent, a);
    return v.length ? Math.max.apply(null, v) - Math.min.apply(null, v) : 0;
  });
  var byExtent = [0, 1, 2].sort(function (a, b) { return extent[b] - extent[a] || a - b; });
  var plan = [Math.min(byExtent[0], byExtent[1]), Math.max(byExtent[0], byExtent[1])];
  var views = [["plan view", plan[0], plan[1], volume && plan[1] === 1],
               ["side view", byExtent[0], byExtent[2], volume && byExtent[2] === 1]];
  var names = ["x", "y", "z"];
  var lostIndex = {};
  lost.forEach(function (f) { lostIndex[f] = true; });
  var lostPoints = T.est.filter(function (p, j) { return lostIndex[T.est_frames[j]]; });
  // A run kfx optimise closed loops over: the raw odometry too, and the accepted loops' ends on it.
  var O = KFX.odometry, LC = KFX.loop_closure;
  var loopEnds = [];
  if (O && LC) {
    var odometryAt = {};
    O.est_frames.forEach(function (f, j) { odometryAt[f] = O.est[j]; });
    (LC.loops || []).forEach(function (l) {
      if (!l.accepted) return;
      [l.from_pose, l.to_pose].forEach(function (p) { if (odometryAt[p]) loopEnds.push(odometryAt[p]); });
    });
  }
  views.forEach(function (v) {
    var series = [];
    if (T.gt) series.push({ name: "ground truth", x: column(T.gt, v[1]), y: column(T.gt, v[2]), color: "#888" });
    if (O) series.push({ name: "odometry (before loop closure)", x: column(O.est, v[1]), y: column(O.est, v[2]), color: "#f4a261" });
    if (loopEnds.length) series.push({ name: "accepted loops' ends (odometry)", x: column(loopEnds, v[1]), y: column(loopEnds, v[2]), color: "#2a9d8f", dots: true });
    series.push({ name: O ? "kfx, loops closed" : "kfx", x: column(T.est, v[1]), y: column(T.est, v[2]), color: "#1f6fd0" });
    if (lostPoints.length) series.push({ name: "tracking failed", x: column(lostPoints, v[1]), y: column(lostPoints, v[2]), color: "#e33", dots: true });
    plot(el("trajectory-plots"), { title: "Trajectory, " + v[0] + " (" + names[v[1]] + ", " + names[v[2]] + ")",
      xlabel: names[v[1]] + " (m, " + T.frame + " frame)", ylabel: names[v[2]] + " (m)" + (v[3] ? ", down" : ""),
      series: series, equal: true, flipY: v[3] });
  });

  // ---- Loop closure (kfx optimise): the counts, the ATE before and after, every loop ----
  if (LC) {
    var lc = ["<h2>Loop closure</h2>", '<table class="summary">'];
    var lcRows = [["keyframes", LC.keyframes], ["loops proposed", LC.loops_proposed],
      ["loops accepted", LC.loops_accepted],
      ["rejected by verification", LC.loops_rejected_by_verification],
      ["rejected by the pose graph", LC.loops_rejected_by_pose_graph],
      ["ATE RMSE before (odometry)", LC.odometry_ate_rmse_m === undefined ? "—" : fixed(100 * LC.odometry_ate_rmse_m, 2) + " cm"],
      ["ATE RMSE after", S.ate_rmse_m === undefined ? "—" : fixed(100 * S.ate_rmse_m, 2) + " cm"]];
    lcRows.forEach(function (r) { lc.push("<tr><th>" + text(r[0]) + "</th><td>" + text(r[1]) + "</td></tr>"); });
    lc.push("</table>");
    if ((LC.loops || []).length) {
      lc.push('<table class="summary"><tr><th>from pose</th><th>to pose</th><th>source</th><th>verified</th>' +
              "<th>inliers</th><th>residual (mm)</th><th>χ² before</th><th>χ² after</th><th>accepted</th></tr>");
      LC.loops.forEach(function (l) {
        lc.push("<tr>" + [l.from_pose, l.to_pose, l.source, l.verified ? "yes" : "no: " + l.rejection,
          fixed(100 * l.inlier_fraction, 0) + " %", fixed(1000 * l.residual_rms_m, 1),
          fixed(l.chi2_initial, 2), fixed(l.chi2_final, 2), l.accepted ? "yes" : "no"].map(function (c) {
          return "<td>" + text(c) + "</td>";
        }).join("") + "</tr>");
      });
      lc.push("</table>");
    }
    el("loop-closure").innerHTML = lc.join("");
  }

  // ---- Per-frame plots: translational error, stage times; lost frames as red lines ----
  if (T.errors_m) {
    var squares = T.errors_m.reduce(function (sum, e) { return sum + e * e; }, 0);
    var rmse = Math.sqrt(squares / Math.max(1, T.errors_m.length));
    plot(el("frame-plots"), { title: "Translational error after alignment (RMSE " + fixed(100 * rmse, 2) + " cm)",
      xlabel: "frame", ylabel: "error (cm)",
      series: [{ name: "|kfx − ground truth|", x: T.est_frames, y: T.errors_m.map(function (e) { return 100 * e; }), color: "#1f6fd0" }],
      vlines: lost, zeroY: true });
  }
  var stages = [["preprocessing", "#2a9d8f"], ["tracking", "#e76f51"], ["integration", "#264653"],
                ["raycasting", "#e9c46a"], ["rendering", "#9b5de5"]];
  plot(el("frame-plots"), { title: "Stage times (slambench.log)", xlabel: "frame", ylabel: "time (ms)",
    series: stages.filter(function (s) { return L[s[0]]; }).map(function (s) {
      return { name: s[0], x: L.frame, y: L[s[0]].map(function (t) { return 1000 * t; }), color: s[1] };
    }), vlines: lost, zeroY: true });

  // ---- Renders ----
  if (!KFX.renders.length) {
    el("renders").innerHTML = '<div class="note">No renders in this run (kfx run --renders writes them).</div>';
  } else {
    var colour = KFX.renders.some(function (r) { return r.colour; });
    var html = ['<table class="renders"><tr><td>depth</td><td>tracking (grey inlier, red outside, green no reference normal, blue too far, yellow normal mismatch, black no input, pink not tracked)</td><td>model</td>' + (colour ? "<td>model colour</td>" : "") + "</tr>"];
    KFX.renders.forEach(function (r) {
      html.push("<tr>" + ["depth", "track", "volume"].concat(colour ? ["colour"] : []).map(function (k) {
        return "<td>" + (r[k] ? '<img alt="' + k + " " + r.frame + '" src="' + r[k] + '"><br>' : "") + "frame " + r.frame + "</td>";
      }).join("") + "</tr>");
    });
    html.push("</table>");
    var shownNote = KFX.render_frames_in_run > KFX.renders.length
      ? '<div class="note">Showing the renders of ' + KFX.renders.length + " of the " + KFX.render_frames_in_run +
        " frames rendered, evenly spread over the run (all are in renders/).</div>"
      : '<div class="note">The renders of all ' + KFX.renders.length + " frame(s) rendered.</div>";
    el("renders").innerHTML = shownNote + html.join("");
  }

  // ---- 3D view: mesh.ply (thinned if large) and the camera path, both in the volume frame ----
  function decode(b64, Type) {
    var bytes = atob(b64), buffer = new Uint8Array(bytes.length);
    for (var k = 0; k < bytes.length; ++k) buffer[k] = bytes.charCodeAt(k);
    return new Type(buffer.buffer);
  }
  var mesh = KFX.mesh, notes = [];
  if (mesh.missing) notes.push("No mesh: " + mesh.missing + ".");
  else notes.push("mesh.ply: " + mesh.source_vertices + " vertices, " + mesh.source_triangles + " triangles" +
                  (mesh.thinning_cell_m ? "; shown thinned to " + mesh.triangles + " triangles (" + fixed(100 * mesh.thinning_cell_m, 2) + " cm cells)" : "") +
                  ". Drag to orbit, right-drag to pan, wheel to zoom. Red: camera path.");
  if (!KFX.has_three) notes.push("The 3D view needs three.js (Debian package libjs-three), not found in " + KFX.three_dir + " when the report was made.");
  el("view3d-note").textContent = notes.join(" ");
  if (KFX.has_three) {
    var box = el("view3d");
    var renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(box.clientWidth, box.clientHeight);
    var background = new THREE.Color(0x202428);
    renderer.setClearColor(background);
    box.appendChild(renderer.domElement);
    var scene = new THREE.Scene();
    var camera = new THREE.PerspectiveCamera(50, box.clientWidth / box.clientHeight, 0.01, 100);
    camera.up.set(0, -1, 0);  // the volume frame's y points down (camera convention)
    scene.add(new THREE.AmbientLight(0xffffff, 0.35));
    var light = new THREE.DirectionalLight(0xffffff, 0.75);
    camera.add(light);  // a headlight: the side the viewer sees is lit
    scene.add(camera);
    var bounds = new THREE.Box3();
    if (!mesh.missing && mesh.triangles > 0) {
      var geometry = new THREE.BufferGeometry();
      geometry.setAttribute("position", new THREE.BufferAttribute(decode(mesh.positions, Float32Array), 3));
      geometry.setIndex(new THREE.BufferAttribute(decode(mesh.indices, Uint32Array), 1));
      geometry.computeVertexNormals();
      var material = { color: 0xd8d2c4, side: THREE.DoubleSide };
      if (mesh.colours) {  // per-vertex colour (uchar red green blue in mesh.ply)
        geometry.setAttribute("color", new THREE.BufferAttribute(decode(mesh.colours, Uint8Array), 3, true));
        material = { color: 0xffffff, side: THREE.DoubleSide,
                     vertexColors: THREE.VertexColors !== undefined ? THREE.VertexColors : true };
      }
      var model = new THREE.Mesh(geometry, new THREE.MeshLambertMaterial(material));
      scene.add(model);
      geometry.computeBoundingBox();
      bounds.union(geometry.boundingBox);
    }
    var path = new THREE.BufferGeometry().setFromPoints(T.volume_path.map(function (p) { return new THREE.Vector3(p[0], p[1], p[2]); }));
    var pathLine = new THREE.Line(path, new THREE.LineBasicMaterial({ color: 0xff3030 }));
    scene.add(pathLine);
    path.computeBoundingBox();
    bounds.union(path.boundingBox);
    var centre = bounds.getCenter(new THREE.Vector3());
    var radius = Math.max(0.1, bounds.getSize(new THREE.Vector3()).length() / 2);
    // Start above and behind the cameras (which look down +z), looking at the model's centre,
    // far enough that the sphere around the model and the path fits the narrower field of view.
    var halfFov = Math.min(camera.fov * Math.PI / 360, Math.atan(Math.tan(camera.fov * Math.PI / 360) * camera.aspect));
    var distance = 1.05 * radius / Math.sin(halfFov);
    camera.position.copy(centre).add(new THREE.Vector3(0, -0.9, -1.6).normalize().multiplyScalar(distance));
    camera.far = Math.max(100, 4 * distance);
    camera.updateProjectionMatrix();
    camera.lookAt(centre);
    var controls = new THREE.OrbitControls(camera, renderer.domElement);
    controls.target.copy(centre);
    controls.update();
    function draw() { renderer.render(scene, camera); }
    controls.addEventListener("change", draw);
    window.addEventListener("resize", function () {
      camera.aspect = box.clientWidth / box.clientHeight;
      camera.updateProjectionMatrix();
      renderer.setSize(box.clientWidth, box.clientHeight);
      draw();
    });
    // Self-check for tests: pixels of the model alone (path hidden) that differ from the
    // background; then the full first frame.
    pathLine.visible = false;
    draw();
    var gl = renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    var pixels = new Uint8Array(w * h * 4), drawn = 0, edge = 0;
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    var bg = [background.r * 255, background.g * 255, background.b * 255];
    for (var p = 0; p < w * h; ++p) {
      if (Math.abs(pixels[4 * p] - bg[0]) + Math.abs(pixels[4 * p + 1] - bg[1]) + Math.abs(pixels[4 * p + 2] - bg[2]) > 24) {
        ++drawn;
        var px = p % w, py = Math.floor(p / w);
        if (px === 0 || py === 0 || px === w - 1 || py === h - 1) ++edge;  // the model cut off
      }
    }
    document.body.setAttribute("data-mesh-pixels", String(drawn));
    document.body.setAttribute("data-mesh-edge-pixels", String(edge));
    document.body.setAttribute("data-view-pixels", String(w * h));
    pathLine.visible = true;
    draw();
  }
  var root = document.documentElement;
  document.body.setAttribute("data-scrollbars", String(root.scrollWidth > root.clientWidth || root.scrollHeight > root.clientHeight));
  if (!window.kfxErrors.length) document.body.setAttribute("data-status", "ok");
})();
