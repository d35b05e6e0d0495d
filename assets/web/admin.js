// Admin dashboard: refreshes the progress figures every five seconds.
(function () {
  'use strict';
  const rows = document.querySelectorAll('[data-progress]');
  if (rows.length === 0) return;
  async function refresh() {
    for (const row of rows) {
      try {
        const res = await fetch(row.dataset.progress, { credentials: 'same-origin' });
        if (!res.ok) continue;
        const p = await res.json();
        for (const cell of row.querySelectorAll('[data-field]')) {
          const value = p[cell.dataset.field];
          if (value !== undefined) cell.textContent = value;
        }
      } catch (e) { /* offline: keep the last figures */ }
    }
  }
  setInterval(refresh, 5000);
})();
