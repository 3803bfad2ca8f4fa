// peis view: the page's code. It speaks the view's WebSocket protocol
// (docs/operating.md): it sends the table's filter, the plotted tuple and
// edits, and applies the updates the view sends at most --rate times a
// second. No libraries: plain DOM, SVG and canvas.
'use strict';

(function () {
  const $ = (id) => document.getElementById(id);
  const SVG = 'http://www.w3.org/2000/svg';

  const state = {
    socket: null,
    hello: null,
    offsetMs: 0,          // server clock minus this browser's clock
    rows: new Map(),      // id -> {row, tr, cells}
    order: [],            // ids sorted by owner, key
    graph: null,
    peers: new Map(),     // id -> graph node
    metaRows: new Map(),
    metaLog: [],
    plot: { tuple: null, samples: [] },
    pictures: new Map(),  // id -> picture state
    requests: new Map(),  // request id -> what to do with the reply
    nextRequest: 1,
    updates: 0,
    updateTimes: [],
    reconnectDelay: 500,
  };

  // ---- helpers ----------------------------------------------------------

  function el(tag, className, text) {
    const e = document.createElement(tag);
    if (className) e.className = className;
    if (text !== undefined && text !== null) e.textContent = text;
    return e;
  }
  function svg(tag, attributes) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attributes || {})) e.setAttribute(k, v);
    return e;
  }
  function serverNowUs() { return (Date.now() + state.offsetMs) * 1000; }
  function compareIds(a, b) {
    const ra = state.rows.get(a).row, rb = state.rows.get(b).row;
    if (ra.owner !== rb.owner) return ra.owner - rb.owner;
    return ra.key < rb.key ? -1 : ra.key > rb.key ? 1 : 0;
  }
  function peerName(id) {
    const p = state.peers.get(id);
    return p ? p.name : null;
  }
  function ownerText(id) {
    const name = peerName(id);
    return name ? name + ' (' + id + ')' : String(id);
  }
  function formatAge(us) {
    if (!(us >= 0)) return '';
    const s = us / 1e6;
    if (s < 1) return (s * 1000).toFixed(0) + ' ms';
    if (s < 60) return s.toFixed(1) + ' s';
    if (s < 3600) return (s / 60).toFixed(1) + ' min';
    if (s < 86400) return (s / 3600).toFixed(1) + ' h';
    return (s / 86400).toFixed(1) + ' d';
  }
  function formatRate(rate) {
    if (!rate) return '';
    return rate >= 10 ? rate.toFixed(0) + '/s' : rate.toFixed(rate >= 1 ? 1 : 2) + '/s';
  }
  function formatBytes(n) {
    if (n < 1024) return n + ' B';
    if (n < 1024 * 1024) return (n / 1024).toFixed(1) + ' KiB';
    return (n / 1024 / 1024).toFixed(1) + ' MiB';
  }
  function formatTime(us) {
    const d = new Date(us / 1000);
    const pad = (n, w) => String(n).padStart(w || 2, '0');
    return pad(d.getHours()) + ':' + pad(d.getMinutes()) + ':' + pad(d.getSeconds()) + '.' +
        pad(d.getMilliseconds(), 3);
  }
  function isPicture(mimetype) {
    return ['image/png', 'image/jpeg', 'image/gif', 'image/webp'].includes(mimetype) ||
        mimetype.startsWith('image/x-raw;');
  }
  function statusClass(value) {
    return ['running', 'waiting', 'error', 'initializing'].includes(value) ? value : '';
  }
  function showMessage(text) {
    const box = el('div', 'message', text);
    $('messages').appendChild(box);
    setTimeout(() => box.remove(), 8000);
  }
  function send(message) {
    if (state.socket && state.socket.readyState === WebSocket.OPEN) {
      state.socket.send(JSON.stringify(message));
      return true;
    }
    return false;
  }

  // ---- the connection ---------------------------------------------------

  function connect() {
    const connection = $('connection');
    connection.textContent = 'connecting…';
    connection.className = 'connection connecting';
    const socket = new WebSocket('ws://' + location.host + '/ws');
    state.socket = socket;
    socket.onopen = () => {
      state.reconnectDelay = 500;
      connection.textContent = 'live';
      connection.className = 'connection open';
    };
    socket.onmessage = (event) => {
      let message;
      try {
        message = JSON.parse(event.data);
      } catch (e) {
        showMessage('the view sent something that is not JSON: ' + e);
        return;
      }
      handle(message);
    };
    socket.onclose = (event) => {
      connection.className = 'connection closed';
      let why = 'disconnected';
      if (event.code === 1009) why = 'closed: a message was too big for the view';
      else if (event.reason) why = 'closed: ' + event.reason;
      connection.textContent = why + ' — reconnecting';
      for (const [, pending] of state.requests) pending.fail('the connection closed before an answer');
      state.requests.clear();
      setTimeout(connect, state.reconnectDelay);
      state.reconnectDelay = Math.min(state.reconnectDelay * 2, 5000);
    };
  }

  function handle(message) {
    switch (message.type) {
      case 'hello': return onHello(message);
      case 'update': return onUpdate(message);
      case 'reply': return onReply(message);
      case 'error': return onError(message);
      default: showMessage('unknown message from the view: ' + message.type);
    }
  }

  function onHello(hello) {
    state.hello = hello;
    $('ecology').textContent = 'ecology ' + hello.ecology + ' · view PEIS ' + hello.self;
    $('meta-filters').textContent = hello.metaFilters.join('  ');
    const filter = $('filter');
    if (filter.value.trim() === '') filter.value = hello.filter;
    else send({ op: 'filter', pattern: filter.value });
    if (state.plot.tuple) send({ op: 'plot', tuple: state.plot.tuple });
  }

  function onError(message) {
    if (message.op === 'filter') {
      $('filter-error').textContent = message.error;
      return;
    }
    if (message.request !== undefined && state.requests.has(message.request)) {
      const pending = state.requests.get(message.request);
      state.requests.delete(message.request);
      pending.fail(message.error);
      return;
    }
    showMessage(message.error);
  }

  function onReply(reply) {
    const pending = state.requests.get(reply.request);
    if (!pending) return;
    state.requests.delete(reply.request);
    if (reply.ok) pending.ok(reply);
    else pending.fail(reply.error, reply.code);
  }

  function request(message, ok, fail) {
    message.request = state.nextRequest++;
    state.requests.set(message.request, { ok, fail });
    if (!send(message)) {
      state.requests.delete(message.request);
      fail('not connected to the view');
    }
  }

  function onUpdate(update) {
    state.offsetMs = update.now / 1000 - Date.now();
    state.updates++;
    const t = Date.now();
    state.updateTimes.push(t);
    while (state.updateTimes.length && t - state.updateTimes[0] > 5000) state.updateTimes.shift();
    if (update.graph) onGraph(update.graph);
    if (update.table) onTable(update.table);
    if (update.rates) {
      for (const [id, rate] of Object.entries(update.rates)) {
        const entry = state.rows.get(id);
        if (entry) {
          entry.row.rate = rate;
          entry.cells.rate.textContent = formatRate(rate);
        }
      }
    }
    if (update.meta) onMeta(update.meta);
    if (update.log) onLog(update.log);
    if (update.plot) onPlot(update.plot);
    updateCounts();
  }

  function updateCounts() {
    const peers = state.graph ? state.graph.nodes.filter((n) => !n.tool).length : 0;
    const rate = state.updateTimes.length / 5;
    $('counts').textContent = peers + ' PEIS · ' + state.rows.size + ' tuples shown · ' +
        rate.toFixed(1) + ' updates/s (at most ' + (state.hello ? state.hello.updateRate : '?') + ')';
  }

  // ---- the tuple table --------------------------------------------------

  function onTable(part) {
    if (part.reset) {
      $('filter-error').textContent = '';
      $('tuples').tBodies[0].replaceChildren();
      state.rows.clear();
      state.order = [];
      for (const [id] of state.pictures) removePicture(id);
      if (part.filter && document.activeElement !== $('filter')) $('filter').value = part.filter;
    }
    for (const row of part.rows) upsertRow(row);
    for (const id of part.deleted) removeRow(id);
  }

  function valueCell(cell, row) {
    cell.replaceChildren();
    if (row.binary) {
      cell.appendChild(el('span', 'meta-data', '‹binary, ' + formatBytes(row.size) + ', ' + row.mimetype + '›'));
      return;
    }
    const text = el('span', '', row.value + (row.truncated ? '…' : ''));
    const statusKind = statusClass(row.value);
    if (row.key === 'status' && statusKind) {
      text.className = 'badge ' + statusKind;
    } else if (row.key.endsWith('.status')) {
      if (row.value === 'ok') text.className = 'badge ok';
      else if (row.value === 'busy') text.className = 'badge busy';
      else if (row.value.startsWith('error')) text.className = 'badge error';
    } else if (row.key === 'cause.names' && row.value !== '') {
      text.className = 'causes';
    }
    cell.appendChild(text);
    if (row.truncated) cell.appendChild(el('span', 'meta-data', ' (' + formatBytes(row.size) + ')'));
  }

  function upsertRow(row) {
    let entry = state.rows.get(row.id);
    if (!entry) {
      const tr = el('tr');
      tr.dataset.tuple = row.id;
      const cells = {
        owner: el('td', 'owner'), key: el('td', 'key'), value: el('td', 'value'),
        seqno: el('td', 'num seqno'), age: el('td', 'num age'), rate: el('td', 'num rate'),
        actions: el('td', 'actions'),
      };
      for (const c of Object.values(cells)) tr.appendChild(c);
      entry = { row, tr, cells, actionsFor: null };
      state.rows.set(row.id, entry);
      insertSorted(row.id);
    } else {
      entry.tr.classList.remove('flash');
      void entry.tr.offsetWidth;  // restarts the animation
      entry.tr.classList.add('flash');
    }
    entry.row = row;
    const c = entry.cells;
    c.owner.textContent = ownerText(row.owner);
    c.key.textContent = row.key;
    valueCell(c.value, row);
    c.value.title = row.mimetype + ', ' + formatBytes(row.size) + ', written by PEIS ' + row.creator;
    c.seqno.textContent = row.seqno;
    c.rate.textContent = formatRate(row.rate);
    updateAge(entry);
    entry.tr.classList.toggle('gone', state.graph !== null && !state.peers.has(row.owner));
    entry.tr.classList.toggle('kernel', row.key.startsWith('kernel.'));
    const kind = (row.number !== undefined ? 'n' : '') + (isPicture(row.mimetype) ? 'p' : '');
    if (entry.actionsFor !== kind) {
      entry.actionsFor = kind;
      c.actions.replaceChildren();
      const edit = el('button', 'edit', 'edit');
      edit.addEventListener('click', () => startEdit(row.id));
      c.actions.appendChild(edit);
      if (row.number !== undefined) {
        const plot = el('button', 'plot', 'plot');
        plot.addEventListener('click', () => choosePlot(row.id));
        c.actions.appendChild(plot);
      }
    }
    if (isPicture(row.mimetype)) updatePicture(row);
    else if (state.pictures.has(row.id)) removePicture(row.id);
  }

  function insertSorted(id) {
    let lo = 0, hi = state.order.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (compareIds(state.order[mid], id) < 0) lo = mid + 1; else hi = mid;
    }
    state.order.splice(lo, 0, id);
    const body = $('tuples').tBodies[0];
    const before = lo + 1 < state.order.length ? state.rows.get(state.order[lo + 1]).tr : null;
    body.insertBefore(state.rows.get(id).tr, before);
  }

  function removeRow(id) {
    const entry = state.rows.get(id);
    if (!entry) return;
    entry.tr.remove();
    state.rows.delete(id);
    const at = state.order.indexOf(id);
    if (at >= 0) state.order.splice(at, 1);
    removePicture(id);
  }

  function updateAge(entry) {
    const stamp = entry.row.tsWrite || entry.row.arrival;
    entry.cells.age.textContent = formatAge(Math.max(0, serverNowUs() - stamp));
  }

  setInterval(() => {
    for (const entry of state.rows.values()) updateAge(entry);
    for (const [id, entry] of state.metaRows) {
      entry.cells.age.textContent = formatAge(Math.max(0, serverNowUs() - (entry.row.tsWrite || entry.row.arrival)));
      void id;
    }
    updateCounts();
  }, 500);

  function showKernelTuples() {
    $('tuples').classList.toggle('hide-kernel', !$('show-kernel').checked);
  }
  $('show-kernel').addEventListener('change', showKernelTuples);
  showKernelTuples();

  $('filter-form').addEventListener('submit', (event) => {
    event.preventDefault();
    $('filter-error').textContent = '';
    if (!send({ op: 'filter', pattern: $('filter').value })) $('filter-error').textContent = 'not connected';
  });

  // ---- edits ------------------------------------------------------------

  function setResult(text, kind) {
    const result = $('edit-result');
    result.textContent = text;
    result.className = kind;
  }

  function startEdit(id) {
    $('edit-name').value = id;
    setResult('reading ' + id + '…', 'busy');
    request({ op: 'get', tuple: id }, (reply) => {
      $('edit-value').value = reply.value;
      $('edit-mimetype').value = reply.mimetype || 'text/plain';
      setResult('seqno ' + reply.seqno + ': edit the value and Set', 'busy');
      $('edit-value').focus();
    }, (error) => {
      $('edit-value').value = '';
      setResult(error, 'failed');
    });
  }

  $('edit-form').addEventListener('submit', (event) => {
    event.preventDefault();
    const tuple = $('edit-name').value.trim();
    const value = $('edit-value').value;
    const mimetype = $('edit-mimetype').value.trim() || 'text/plain';
    if (!tuple) {
      setResult('name the tuple: OWNER.KEY', 'failed');
      return;
    }
    const bytes = new TextEncoder().encode(value).length;
    if (state.hello && bytes > state.hello.maxEditBytes) {
      setResult('a value of ' + bytes + ' bytes is over this view\'s edit limit of ' +
          state.hello.maxEditBytes + ' bytes', 'failed');
      return;
    }
    setResult('writing ' + tuple + '…', 'busy');
    request({ op: 'set', tuple, value, mimetype }, (reply) => {
      setResult('accepted: ' + reply.tuple + ' seqno ' + reply.seqno, 'ok');
    }, (error, code) => {
      setResult('refused' + (code ? ' (' + code + ')' : '') + ': ' + error, 'failed');
    });
  });

  // ---- the plot ---------------------------------------------------------

  function choosePlot(id) {
    state.plot = { tuple: id, samples: [] };
    $('plot-name').textContent = id;
    send({ op: 'plot', tuple: id });
    drawPlot();
  }

  function onPlot(plot) {
    if (plot.tuple !== state.plot.tuple) return;
    if (plot.reset) state.plot.samples = [];
    for (const s of plot.samples) state.plot.samples.push(s);
    if (state.plot.samples.length > 5000) state.plot.samples.splice(0, state.plot.samples.length - 5000);
    drawPlot();
  }

  function drawPlot() {
    const canvas = $('plot');
    const ratio = window.devicePixelRatio || 1;
    const width = canvas.clientWidth || 760, height = canvas.clientHeight || 220;
    if (canvas.width !== width * ratio) { canvas.width = width * ratio; canvas.height = height * ratio; }
    const g = canvas.getContext('2d');
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, width, height);
    g.font = '11px sans-serif';
    g.fillStyle = '#6b7280';
    const samples = state.plot.samples;
    if (!state.plot.tuple) return;
    if (samples.length === 0) {
      g.fillText('no numeric samples of ' + state.plot.tuple + ' yet', 12, 20);
      return;
    }
    const left = 56, right = 10, top = 10, bottom = 22;
    const t0 = samples[0][0], t1 = Math.max(samples[samples.length - 1][0], t0 + 1);
    let lo = Infinity, hi = -Infinity;
    for (const [, v] of samples) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    if (lo === hi) { lo -= 1; hi += 1; }
    const pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
    const x = (t) => left + (t - t0) / (t1 - t0) * (width - left - right);
    const y = (v) => top + (hi - v) / (hi - lo) * (height - top - bottom);
    g.strokeStyle = '#dde1e7';
    g.lineWidth = 1;
    for (let i = 0; i <= 4; i++) {
      const v = lo + (hi - lo) * i / 4;
      g.beginPath(); g.moveTo(left, y(v)); g.lineTo(width - right, y(v)); g.stroke();
      g.fillText(Number(v.toPrecision(4)).toString(), 4, y(v) + 4);
    }
    g.fillText(formatTime(t0), left, height - 6);
    const last = formatTime(t1);
    g.fillText(last, width - right - g.measureText(last).width, height - 6);
    g.strokeStyle = '#2f6fd6';
    g.lineWidth = 1.6;
    g.beginPath();
    samples.forEach(([t, v], i) => (i ? g.lineTo(x(t), y(v)) : g.moveTo(x(t), y(v))));
    g.stroke();
    g.fillStyle = '#2f6fd6';
    const [lt, lv] = samples[samples.length - 1];
    g.beginPath(); g.arc(x(lt), y(lv), 3, 0, 2 * Math.PI); g.fill();
    g.fillText(String(lv), Math.min(x(lt) + 6, width - 60), y(lv) - 6);
  }
  window.addEventListener('resize', drawPlot);

  // ---- pictures ---------------------------------------------------------

  function updatePicture(row) {
    let p = state.pictures.get(row.id);
    if (!p) {
      const figure = el('figure');
      figure.dataset.tuple = row.id;
      const img = el('img');
      img.alt = row.id;
      const caption = el('figcaption');
      const error = el('div', 'picture-error');
      figure.append(img, caption, error);
      $('images').appendChild(figure);
      p = { figure, img, caption, error, wanted: 0, shown: -1, loading: false, last: 0, url: null, timer: null };
      state.pictures.set(row.id, p);
    }
    p.wanted = row.seqno;
    p.caption.textContent = ownerText(row.owner) + ' · ' + row.key + ' · seqno ' + row.seqno;
    loadPicture(row.id);
  }

  // Loads the newest picture once the last one arrived, at most imageRate a second.
  function loadPicture(id) {
    const p = state.pictures.get(id);
    if (!p || p.loading || p.shown === p.wanted || p.timer) return;
    const interval = 1000 / (state.hello ? state.hello.imageRate : 2);
    const wait = p.last + interval - Date.now();
    if (wait > 0) {
      p.timer = setTimeout(() => { p.timer = null; loadPicture(id); }, wait);
      return;
    }
    p.loading = true;
    p.last = Date.now();
    const seqno = p.wanted;
    fetch('/image?tuple=' + encodeURIComponent(id) + '&seqno=' + seqno)
      .then((response) => response.ok ? response.blob() : response.text().then((t) => { throw new Error(t); }))
      .then((blob) => {
        if (p.url) URL.revokeObjectURL(p.url);
        p.url = URL.createObjectURL(blob);
        p.img.src = p.url;
        p.error.textContent = '';
      })
      .catch((e) => { p.error.textContent = String(e.message || e); })
      .finally(() => {
        p.loading = false;
        p.shown = seqno;
        if (state.pictures.get(id) === p) loadPicture(id);
      });
  }

  function removePicture(id) {
    const p = state.pictures.get(id);
    if (!p) return;
    if (p.timer) clearTimeout(p.timer);
    if (p.url) URL.revokeObjectURL(p.url);
    p.figure.remove();
    state.pictures.delete(id);
  }

  // ---- the meta-level ---------------------------------------------------

  function onMeta(part) {
    const body = $('meta-rows').tBodies[0];
    if (part.reset) {
      body.replaceChildren();
      state.metaRows.clear();
    }
    for (const row of part.rows) {
      let entry = state.metaRows.get(row.id);
      if (!entry) {
        const tr = el('tr');
        tr.dataset.tuple = row.id;
        const cells = { name: el('td', 'key'), value: el('td', 'value'), seqno: el('td', 'num'), age: el('td', 'num') };
        for (const c of Object.values(cells)) tr.appendChild(c);
        entry = { tr, cells, row };
        state.metaRows.set(row.id, entry);
        const ids = [...state.metaRows.keys()].sort();
        const next = ids[ids.indexOf(row.id) + 1];
        body.insertBefore(tr, next ? state.metaRows.get(next).tr : null);
      }
      entry.row = row;
      entry.cells.name.textContent = (peerName(row.owner) || row.owner) + '.' + row.key;
      valueCell(entry.cells.value, row);
      entry.cells.seqno.textContent = row.seqno;
    }
    for (const id of part.deleted) {
      const entry = state.metaRows.get(id);
      if (entry) { entry.tr.remove(); state.metaRows.delete(id); }
    }
    if (state.metaRows.size === 0 && body.children.length === 0) {
      const tr = el('tr');
      const td = el('td', 'empty-note', 'no tuples of the meta-level yet (' +
          (state.hello ? state.hello.metaFilters.join(', ') : '') + ')');
      td.colSpan = 4;
      tr.appendChild(td);
      body.appendChild(tr);
    } else {
      for (const tr of [...body.children]) if (!tr.dataset.tuple) tr.remove();
    }
  }

  function onLog(log) {
    const list = $('meta-log');
    if (log.reset) list.replaceChildren();
    for (const entry of log.entries) {
      const row = entry.row;
      const li = el('li');
      li.appendChild(el('span', 'time', formatTime(row.tsWrite || row.arrival)));
      li.appendChild(el('span', 'name', (peerName(row.owner) || row.owner) + '.' + row.key + ' '));
      if (entry.deleted) li.appendChild(el('span', 'deleted', 'deleted'));
      else li.appendChild(el('span', 'value', row.binary ? '‹binary›' : '= ' + row.value));
      list.insertBefore(li, list.firstChild);
    }
    while (list.children.length > 200) list.lastChild.remove();
  }

  // ---- the graph, the PEIS and the configuration -------------------------

  function onGraph(graph) {
    state.graph = graph;
    state.peers = new Map(graph.nodes.map((n) => [n.id, n]));
    drawGraph();
    fillPeis();
    fillConfiguration();
    for (const entry of state.rows.values()) {
      entry.cells.owner.textContent = ownerText(entry.row.owner);
      entry.tr.classList.toggle('gone', !state.peers.has(entry.row.owner));
    }
  }

  function nodeColour(node) {
    const s = statusClass(node.status);
    return s ? 'var(--' + s + ')' : 'var(--none)';
  }

  function drawGraph() {
    const graph = state.graph;
    const box = $('graph');
    box.replaceChildren();
    if (!graph) return;
    const showTools = $('show-tools').checked;
    const nodes = graph.nodes.filter((n) => showTools || !n.tool || n.self);
    const width = box.clientWidth || 600, height = box.clientHeight || 380;
    box.setAttribute('viewBox', '0 0 ' + width + ' ' + height);
    const defs = svg('defs');
    const marker = svg('marker', { id: 'arrow', viewBox: '0 0 10 10', refX: 10, refY: 5, markerWidth: 7, markerHeight: 7, orient: 'auto-start-reverse' });
    marker.appendChild(svg('path', { d: 'M 0 0 L 10 5 L 0 10 z', fill: '#8a3ffc' }));
    defs.appendChild(marker);
    box.appendChild(defs);
    if (nodes.length === 0) {
      const t = svg('text', { x: width / 2, y: height / 2, class: 'empty' });
      t.textContent = 'no PEIS reachable yet';
      box.appendChild(t);
      return;
    }
    const cx = width / 2, cy = height / 2;
    const radius = nodes.length === 1 ? 0 : Math.min(width * 0.9, height) / 2 - 30;
    const position = new Map();
    nodes.forEach((n, i) => {
      const a = -Math.PI / 2 + 2 * Math.PI * i / nodes.length;
      position.set(n.id, [cx + radius * Math.cos(a), cy + radius * Math.sin(a)]);
    });
    const nodeRadius = 16;
    for (const [a, b] of graph.links) {
      if (!position.has(a) || !position.has(b)) continue;
      const [x1, y1] = position.get(a), [x2, y2] = position.get(b);
      const line = svg('line', { x1, y1, x2, y2, class: 'link' });
      const title = svg('title');
      title.textContent = 'link ' + ownerText(a) + ' — ' + ownerText(b);
      line.appendChild(title);
      box.appendChild(line);
    }
    for (const c of graph.configuration) {
      if (!position.has(c.consumer)) continue;
      const [x2, y2] = position.get(c.consumer);
      const input = c.key.replace(/^mi-/, '');
      const title = svg('title');
      let path, label;
      if (c.producer !== null && c.producerReachable && position.has(c.producer) && c.producer !== c.consumer) {
        // producer -> consumer, bent to the side so it is not hidden by a link
        const [x1, y1] = position.get(c.producer);
        const dx = x2 - x1, dy = y2 - y1, len = Math.hypot(dx, dy) || 1;
        const ux = dx / len, uy = dy / len;
        const sx = x1 + ux * nodeRadius, sy = y1 + uy * nodeRadius;
        const ex = x2 - ux * (nodeRadius + 2), ey = y2 - uy * (nodeRadius + 2);
        const mx = (sx + ex) / 2 - uy * 28, my = (sy + ey) / 2 + ux * 28;
        path = svg('path', { d: 'M ' + sx + ' ' + sy + ' Q ' + mx + ' ' + my + ' ' + ex + ' ' + ey, class: 'meta', 'marker-end': 'url(#arrow)' });
        label = svg('text', { x: (sx + 2 * mx + ex) / 4, y: (sy + 2 * my + ey) / 4 - 4, class: 'meta-label' });
      } else if (c.producer !== null && c.producer === c.consumer) {
        path = svg('path', { d: 'M ' + (x2 - 8) + ' ' + (y2 - nodeRadius) + ' C ' + (x2 - 30) + ' ' + (y2 - 60) + ' ' + (x2 + 30) + ' ' + (y2 - 60) + ' ' + (x2 + 8) + ' ' + (y2 - nodeRadius - 2), class: 'meta', 'marker-end': 'url(#arrow)' });
        label = svg('text', { x: x2, y: y2 - 52, class: 'meta-label' });
      } else {
        if (c.value === '') continue;  // an input not configured: no link to draw
        path = svg('path', { d: 'M ' + (x2 + 40) + ' ' + (y2 - 40) + ' L ' + (x2 + nodeRadius * 0.75) + ' ' + (y2 - nodeRadius * 0.75), class: 'meta broken', 'marker-end': 'url(#arrow)' });
        label = svg('text', { x: x2 + 44, y: y2 - 44, class: 'meta-label' });
      }
      title.textContent = ownerText(c.consumer) + '.' + c.key + ' ← ' + (c.value || '(nothing)') +
          (c.producer !== null && !c.producerReachable ? ' (producer not reachable)' : '');
      label.textContent = input;
      path.appendChild(title);
      box.append(path, label);
    }
    for (const n of nodes) {
      const [x, y] = position.get(n.id);
      const g = svg('g', { class: 'node' + (n.self ? ' self' : '') + (n.tool ? ' tool' : ''), transform: 'translate(' + x + ',' + y + ')' });
      g.dataset.peis = n.id;
      const circle = svg('circle', { r: nodeRadius, fill: nodeColour(n) });
      const title = svg('title');
      title.textContent = n.name + ' (PEIS ' + n.id + ')' + (n.host ? ' on ' + n.host : '') +
          (n.component ? '\ncomponent ' + n.component : '') + (n.status ? '\nstatus ' + n.status : '') +
          (n.causes ? '\ncause.names ' + n.causes : '') + '\nhops ' + n.hops + (n.tool ? '\na tool' : '');
      circle.appendChild(title);
      // Names outside the circle, away from its centre, so they do not cross links.
      const name = svg('text', { y: y >= cy ? nodeRadius + 13 : -nodeRadius - 5 });
      name.textContent = n.name;
      g.append(circle, name);
      box.appendChild(g);
    }
  }
  $('show-tools').addEventListener('change', drawGraph);
  window.addEventListener('resize', drawGraph);

  function fillPeis() {
    const body = $('peis').tBodies[0];
    body.replaceChildren();
    for (const n of state.graph.nodes) {
      if (n.tool && !n.self && !$('show-tools').checked) continue;
      const tr = el('tr');
      tr.dataset.peis = n.id;
      tr.appendChild(el('td', 'num', n.id));
      tr.appendChild(el('td', '', n.name + (n.self ? ' (this view)' : '')));
      tr.appendChild(el('td', '', n.host));
      tr.appendChild(el('td', 'num', n.hops));
      tr.appendChild(el('td', '', n.component));
      const status = el('td');
      if (n.status) status.appendChild(el('span', 'badge ' + statusClass(n.status), n.status));
      tr.appendChild(status);
      tr.appendChild(el('td', 'causes' + (n.status === 'waiting' ? ' waiting' : ''), n.causes));
      body.appendChild(tr);
    }
  }
  $('show-tools').addEventListener('change', fillPeis);

  function fillConfiguration() {
    const body = $('configuration').tBodies[0];
    body.replaceChildren();
    for (const c of state.graph.configuration) {
      const tr = el('tr');
      tr.dataset.tuple = c.consumer + '.' + c.key;
      const consumer = (peerName(c.consumer) || c.consumer) + '.' + c.key;
      let producer = c.value || '(nothing)';
      if (c.producer !== null) producer = (peerName(c.producer) || c.producer) + '.' + c.producerKey;
      const broken = c.value !== '' && (c.producer === null || !c.producerReachable);
      if (broken) {
        tr.className = 'broken';
        producer += c.producer === null ? ' (does not resolve)' : ' (not reachable)';
      }
      tr.appendChild(el('td', 'key', consumer));
      tr.appendChild(el('td', '', '←'));
      tr.appendChild(el('td', 'key', producer));
      const node = state.peers.get(c.consumer);
      const status = el('td');
      if (node && node.status) status.appendChild(el('span', 'badge ' + statusClass(node.status), node.status + (node.causes ? ': ' + node.causes : '')));
      tr.appendChild(status);
      body.appendChild(tr);
    }
    if (!state.graph.configuration.length) {
      const tr = el('tr');
      const td = el('td', 'empty-note', 'no meta tuples (mi-*) in the ecology');
      td.colSpan = 4;
      tr.appendChild(td);
      body.appendChild(tr);
    }
  }

  connect();
})();
