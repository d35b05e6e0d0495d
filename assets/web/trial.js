// One trial page (one stimulus, or a screen of several side by side, each with its own
// answers): measures the response time from the first painted frame, notes whether the videos
// played to their end, gives a video its coding controls (frame steps, replay,
// speeds) and counts their use with the time in view, and saves the answer with its idempotency key. The page
// moves on only after the server acknowledges the save; until then the answer waits in a queue
// (localStorage) and is sent again with growing pauses, also after a reload.
(function () {
  'use strict';
  const form = document.getElementById('trial');
  if (!form) return;
  const api = form.dataset.api;
  const queueKey = 'facslab-pending:' + api.split('/api/')[0];
  const status = document.getElementById('status');
  const next = document.getElementById('next');
  const stimuli = Array.from(form.querySelectorAll('.stimulus'));
  const stimulus = stimuli[0];
  let shownAt = null;
  // The videos that played to their end since they last started; the save's video_ended says all did.
  const endedVideos = new Set();
  function allEnded() { return endedVideos.size === stimuli.length; }
  // How the media are viewed (study::viewing): replays, frame steps, speeds, time in view.
  const viewing = { replays: 0, frame_steps: 0, speeds: [] };
  let visibleMs = 0;
  let visibleSince = null;

  function painted() {
    requestAnimationFrame(function () {
      if (shownAt !== null) return;
      shownAt = performance.now();
      if (document.visibilityState === 'visible') visibleSince = shownAt;
    });
  }
  document.addEventListener('visibilitychange', function () {
    if (shownAt === null) return;
    if (document.visibilityState === 'visible') visibleSince = performance.now();
    else if (visibleSince !== null) { visibleMs += performance.now() - visibleSince; visibleSince = null; }
  });
  // `now` is the same clock reading as the response time's, so time in view never exceeds it.
  function timeOnTask(now) {
    const since = visibleSince === null ? 0 : now - visibleSince;
    return Math.round((visibleMs + since) * 10) / 10;
  }
  function failed() { form.elements.load_failed.value = '1'; painted(); }
  if (stimulus.tagName === 'VIDEO') {
    stimuli.forEach(function (video) {
      video.addEventListener('playing', painted);
      video.addEventListener('ended', function () { endedVideos.add(video); });
      video.addEventListener('error', failed);
      video.play().catch(function () { /* autoplay refused: the participant presses Play again */ });
    });
    videoControls(stimuli);
  } else {
    let loaded = 0;
    stimuli.forEach(function (image) {
      const shown = function () { loaded += 1; if (loaded === stimuli.length) painted(); };
      if (image.complete && image.naturalWidth > 0) shown();
      else { image.addEventListener('load', shown); image.addEventListener('error', failed); }
    });
  }

  // Coding videos: play/pause, replay, one frame back or forward (paused), slower speeds; by
  // buttons and by keys (, . r p) unless a menu or text field has the focus. Replay and play act
  // on every video of the screen (they play together); the others on the first (coding pages
  // show one video).
  function videoControls(videos) {
    const video = videos[0];
    const fps = Number(video.dataset.fps) || 0;
    const button = function (id) { return document.getElementById(id); };
    const play = button('play');
    function used(rate) { if (viewing.speeds.indexOf(rate) < 0) viewing.speeds.push(rate); }
    function showState() {
      if (!play) return;
      play.textContent = video.paused ? 'Play' : 'Pause';
      play.setAttribute('aria-label', (video.paused ? 'Play' : 'Pause') + ' (key p)');
    }
    video.addEventListener('playing', function () { used(video.playbackRate); showState(); });
    video.addEventListener('pause', showState);
    video.addEventListener('ended', showState);
    video.addEventListener('ratechange', function () { if (!video.paused) used(video.playbackRate); });
    const actions = {
      replay: function () {
        viewing.replays += 1;
        endedVideos.clear();
        videos.forEach(function (v) { v.currentTime = 0; v.play().catch(function () {}); });
      },
      play: function () {
        const start = video.paused;
        videos.forEach(function (v) { if (start) v.play().catch(function () {}); else v.pause(); });
      },
      step: function (frames) {
        if (!fps) return;
        video.pause();
        const last = Math.max(0, Math.floor((video.duration || 0) * fps) - 1);
        const frame = Math.min(last, Math.max(0, Math.round(video.currentTime * fps) + frames));
        video.currentTime = frame / fps;
        viewing.frame_steps += 1;
      },
    };
    const bind = function (id, action) { const b = button(id); if (b) b.addEventListener('click', action); };
    bind('replay', actions.replay);
    bind('play', actions.play);
    bind('step-back', function () { actions.step(-1); });
    bind('step-forward', function () { actions.step(1); });
    document.querySelectorAll('.speed').forEach(function (b) {
      b.addEventListener('click', function () {
        video.playbackRate = Number(b.dataset.speed);
        document.querySelectorAll('.speed').forEach(function (o) { o.setAttribute('aria-pressed', String(o === b)); });
      });
    });
    // Keys only where the coder's controls are (an emotion trial keeps its one Play again button).
    if (!document.querySelector('.player')) return;
    document.addEventListener('keydown', function (event) {
      const t = event.target;
      if (event.ctrlKey || event.metaKey || event.altKey || t.tagName === 'SELECT' || t.tagName === 'TEXTAREA' || (t.tagName === 'INPUT' && t.type !== 'checkbox' && t.type !== 'radio')) return;
      const keys = { ',': function () { actions.step(-1); }, '.': function () { actions.step(1); }, r: actions.replay, p: actions.play };
      const action = keys[event.key];
      if (action) { event.preventDefault(); action(); }
    });
  }

  // AU coding: choosing an AU's intensity or side marks the AU, unmarking it sets its menus
  // back, and "No AU present" is exclusive with the AUs.
  const none = form.elements.no_aus;
  if (none) {
    const rows = Array.from(form.querySelectorAll('.au'));
    rows.forEach(function (row) {
      const box = row.querySelector('input[name=au]');
      const menus = row.querySelectorAll('select');
      menus.forEach(function (menu) {
        menu.addEventListener('change', function () {
          if (menu.value !== '') { box.checked = true; none.checked = false; }
        });
      });
      box.addEventListener('change', function () {
        if (box.checked) none.checked = false;
        else menus.forEach(function (menu) { menu.value = ''; });
      });
    });
    none.addEventListener('change', function () {
      if (!none.checked) return;
      rows.forEach(function (row) {
        row.querySelector('input[name=au]').checked = false;
        row.querySelectorAll('select').forEach(function (menu) { menu.value = ''; });
      });
    });
  }

  function pending() {
    try { return JSON.parse(localStorage.getItem(queueKey) || '[]'); } catch (e) { return []; }
  }
  function remember(items) {
    try { localStorage.setItem(queueKey, JSON.stringify(items)); } catch (e) { /* private mode: memory only */ }
  }

  function sleep(ms) { return new Promise(function (r) { setTimeout(r, ms); }); }

  // Sends one queued save until the server answers; returns the server's reply.
  async function send(item) {
    let pause = 500;
    for (let attempt = 1; ; attempt++) {
      try {
        const res = await fetch(item.url, {
          method: 'POST',
          headers: { 'Content-Type': 'application/json', 'Accept': 'application/json' },
          body: JSON.stringify(item.body),
          credentials: 'same-origin',
        });
        if (res.ok || (res.status >= 400 && res.status < 500 && res.status !== 408 && res.status !== 429)) {
          const reply = await res.json().catch(function () { return {}; });
          return { ok: res.ok, status: res.status, reply: reply };
        }
      } catch (e) { /* network error: retry */ }
      status.textContent = 'Saving your answer… (try ' + (attempt + 1) + '; please keep this page open)';
      await sleep(pause);
      pause = Math.min(pause * 2, 8000);
    }
  }

  async function flush() {
    let items = pending();
    while (items.length > 0) {
      const result = await send(items[0]);
      items = pending().filter(function (i) { return i.body.idempotency_key !== items[0].body.idempotency_key; });
      remember(items);
      if (!result.ok && result.status !== 409) return result;
    }
    return null;
  }

  form.addEventListener('submit', async function (event) {
    event.preventDefault();
    if (!form.reportValidity()) return;
    const fields = [];
    new FormData(form).forEach(function (value, name) {
      if (['idempotency_key', 'rt_ms', 'video_ended', 'load_failed'].indexOf(name) < 0) fields.push([name, String(value)]);
    });
    const now = performance.now();
    const body = {
      idempotency_key: form.elements.idempotency_key.value,
      fields: fields,
      rt_ms: shownAt === null ? null : Math.round((now - shownAt) * 10) / 10,
      video_ended: stimulus.tagName === 'VIDEO' ? allEnded() : null,
      load_failed: form.elements.load_failed.value === '1',
      viewing: { replays: viewing.replays, frame_steps: viewing.frame_steps, speeds: viewing.speeds.slice(), time_on_task_ms: timeOnTask(now) },
    };
    next.disabled = true;
    status.textContent = 'Saving your answer…';
    const items = pending().filter(function (i) { return i.body.idempotency_key !== body.idempotency_key; });
    items.push({ url: api, body: body });
    remember(items);
    const result = await send(items[items.length - 1]);
    remember(pending().filter(function (i) { return i.body.idempotency_key !== body.idempotency_key; }));
    if (result.ok) {
      window.location.replace(result.reply.next);
    } else if (result.status === 409) {
      window.location.replace(result.reply.next || form.action.split('/trial/')[0]);
    } else {
      status.textContent = '';
      const error = document.querySelector('.error') || document.createElement('p');
      error.className = 'error';
      error.setAttribute('role', 'alert');
      error.textContent = result.reply.error || 'Your answer could not be saved.';
      form.querySelector('.questions').prepend(error);
      next.disabled = false;
    }
  });

  // Answers from an earlier view of this page that never got their acknowledgement go first.
  if (pending().length > 0) {
    next.disabled = true;
    status.textContent = 'Saving an earlier answer…';
    flush().then(function () { window.location.replace(form.action.split('/trial/')[0]); });
  }
})();
