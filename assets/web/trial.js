// One trial page: measures the response time from the stimulus's first painted frame, notes
// whether a video played to its end, and saves the answer with its idempotency key. The page
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
  const stimulus = document.getElementById('stimulus');
  let shownAt = null;
  let ended = false;

  function painted() {
    requestAnimationFrame(function () { if (shownAt === null) shownAt = performance.now(); });
  }
  function failed() { form.elements.load_failed.value = '1'; painted(); }
  if (stimulus.tagName === 'VIDEO') {
    stimulus.addEventListener('playing', painted);
    stimulus.addEventListener('ended', function () { ended = true; });
    stimulus.addEventListener('error', failed);
    const replay = document.getElementById('replay');
    if (replay) replay.addEventListener('click', function () { stimulus.currentTime = 0; stimulus.play(); });
    stimulus.play().catch(function () { /* autoplay refused: the participant presses Play again */ });
  } else if (stimulus.complete && stimulus.naturalWidth > 0) {
    painted();
  } else {
    stimulus.addEventListener('load', painted);
    stimulus.addEventListener('error', failed);
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
    const body = {
      idempotency_key: form.elements.idempotency_key.value,
      fields: fields,
      rt_ms: shownAt === null ? null : Math.round((performance.now() - shownAt) * 10) / 10,
      video_ended: stimulus.tagName === 'VIDEO' ? ended : null,
      load_failed: form.elements.load_failed.value === '1',
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
