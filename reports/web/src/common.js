// Shared helpers of the report pages: the embedded data, DOM building, number formatting, Chart.js set-up.
import {
  Chart, LineController, ScatterController, LineElement, PointElement, LinearScale, Filler, Legend, Tooltip, Title,
} from 'chart.js';

Chart.register(LineController, ScatterController, LineElement, PointElement, LinearScale, Filler, Legend, Tooltip, Title);
Chart.defaults.animation = false;
Chart.defaults.font.family = 'system-ui, "Liberation Sans", Arial, sans-serif';
Chart.defaults.maintainAspectRatio = false;

/** The JSON document embedded in the page. */
export function readData() {
  return JSON.parse(document.getElementById('ctr-data').textContent);
}

/** Creates an element with attributes and children (strings become text nodes). */
export function h(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'class') e.className = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children.flat()) {
    if (c === undefined || c === null || c === false) continue;
    e.appendChild(typeof c === 'string' || typeof c === 'number' ? document.createTextNode(String(c)) : c);
  }
  return e;
}

/** Four significant digits (or '–' for missing values). */
export function fmt(v, digits = 4) {
  if (v === null || v === undefined || !Number.isFinite(v)) return '–';
  if (v !== 0 && (Math.abs(v) >= 1e5 || Math.abs(v) < 1e-3)) return v.toExponential(digits - 1);
  return Number(v.toPrecision(digits)).toString();
}

export const DEG = 180 / Math.PI;

/** Display scale and unit of a quantity name (twist in deg, positions in mm). */
export function unitOf(quantity) {
  if (/^twist/.test(quantity) || /^alpha/.test(quantity)) return { scale: DEG, unit: 'deg' };
  if (/tip_position|^beta|tip_error/.test(quantity)) return { scale: 1e3, unit: 'mm' };
  return { scale: 1, unit: '' };
}

export const COLORS = {
  measured: '#222222', nominal: '#1f77b4', fitted: '#d62728', plus: '#1f77b4', minus: '#ff7f0e',
  band: 'rgba(120,120,120,0.18)', noise: 'rgba(44,160,44,0.16)',
};
export const PALETTE = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#17becf'];

const charts = [];

/**
 * A line/scatter chart in a card. `datasets` use {x, y} points (unsorted x allowed: lines follow the data order).
 * Returns the Chart.
 */
export function chart(parent, { title, xLabel, yLabel, datasets, legend = true, note, height = 320, extra = {} }) {
  const canvas = h('canvas');
  const card = h('figure', { class: 'card chart' }, h('div', { class: 'chart-box', style: `height:${height}px` }, canvas),
    note ? h('figcaption', {}, note) : null);
  parent.appendChild(card);
  const c = new Chart(canvas, {
    type: 'scatter',
    data: { datasets },
    options: {
      responsive: true,
      spanGaps: false,
      elements: { point: { radius: 0, hitRadius: 4 }, line: { borderWidth: 1.6, tension: 0 } },
      plugins: {
        title: { display: !!title, text: title, font: { size: 14, weight: 'bold' } },
        legend: { display: legend, labels: { boxWidth: 14, filter: (it) => !it.text.startsWith('_') } },
        tooltip: { enabled: true, intersect: false, mode: 'nearest' },
      },
      scales: {
        x: { type: 'linear', title: { display: !!xLabel, text: xLabel } },
        y: { type: 'linear', title: { display: !!yLabel, text: yLabel } },
      },
      ...extra,
    },
  });
  charts.push(c);
  return c;
}

/** A line dataset. */
export function line(label, points, color, opts = {}) {
  return { label, data: points, borderColor: color, backgroundColor: color, showLine: true, pointRadius: 0, fill: false, ...opts };
}

/** Every chart made on the page (for tests). */
export function allCharts() { return charts; }

/** Publishes the test / automation hook and marks the page ready. */
export function publish(kind, api = {}) {
  window.ctrReport = {
    kind,
    ready: true,
    chartObjects: charts,
    charts: () => charts.map((c) => ({
      title: c.options.plugins.title.text || '',
      series: c.data.datasets.filter((d) => !String(d.label).startsWith('_')).length,
      points: c.data.datasets.reduce((s, d) => s + d.data.length, 0),
    })),
    seriesCount: () => charts.reduce((s, c) => s + c.data.datasets.filter((d) => !String(d.label).startsWith('_')).length, 0),
    ...api,
  };
  document.body.setAttribute('data-ready', '1');
}

/** Page header with a title and a subtitle line. */
export function header(title, subtitle) {
  return h('header', { class: 'page-header' }, h('h1', {}, title), subtitle ? h('p', { class: 'sub' }, subtitle) : null);
}

/** A table from a header row and body rows (cells are strings or nodes). */
export function table(headers, rows, attrs = {}) {
  return h('table', attrs, h('thead', {}, h('tr', {}, headers.map((x) => h('th', {}, x)))),
    h('tbody', {}, rows.map((r) => h('tr', r.attrs || {}, (r.cells || r).map((x) => h('td', {}, x))))));
}
