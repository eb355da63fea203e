// A Java agent for lcm_spy_test.sh: loaded into hyq-spy's own JVM (JDK_JAVA_OPTIONS=-javaagent:...),
// it waits until the file STOP exists, then reads lcm-spy's channel table on the Swing event thread
// (the same cells the window shows: Channel, Type, Num Msgs, Hz, 1/Hz, Jitter, Bandwidth,
// Undecodable) and writes them tab-separated to OUT, header first; then, as '# field' lines, the
// public fields of the HYQ_HEALTH type lcm-spy decodes with (the class on lcm-spy's own class
// path: what its message viewer lists). Nothing else in lcm-spy changes.
//
//   -javaagent:probe.jar=OUT,STOP
import java.awt.Component;
import java.awt.Container;
import java.awt.Frame;
import java.io.PrintWriter;
import java.nio.file.Files;
import java.nio.file.Path;
import java.nio.file.StandardCopyOption;
import java.util.ArrayList;
import java.util.List;
import javax.swing.JTable;
import javax.swing.SwingUtilities;
import javax.swing.table.TableModel;

public final class SpyTableProbe {
  public static void premain(String args) {
    String[] a = args.split(",", 2);
    Path out = Path.of(a[0]);
    Path stop = Path.of(a[1]);
    Thread t = new Thread(() -> {
      try {
        while (!Files.exists(stop)) Thread.sleep(50);
        StringBuilder sb = new StringBuilder();
        SwingUtilities.invokeAndWait(() -> dump(sb));
        Path tmp = Path.of(out + ".tmp");
        Files.writeString(tmp, sb.toString());
        Files.move(tmp, out, StandardCopyOption.REPLACE_EXISTING, StandardCopyOption.ATOMIC_MOVE);
      } catch (Exception e) {
        e.printStackTrace();
      }
    }, "spy-table-probe");
    t.setDaemon(true);
    t.start();
  }

  static void tables(Component c, List<JTable> found) {
    if (c instanceof JTable) found.add((JTable) c);
    if (c instanceof Container)
      for (Component k : ((Container) c).getComponents()) tables(k, found);
  }

  static void dump(StringBuilder sb) {
    List<JTable> found = new ArrayList<>();
    for (Frame f : Frame.getFrames())
      if (f.isShowing()) tables(f, found);
    sb.append("# tables ").append(found.size()).append('\n');
    try {
      Class<?> health = Class.forName("hyq_lcm.lcmt_hyq_health", false, ClassLoader.getSystemClassLoader());
      for (java.lang.reflect.Field f : health.getFields())
        sb.append("# field ").append(f.getName()).append(' ').append(f.getType().getSimpleName()).append('\n');
    } catch (ClassNotFoundException e) {
      sb.append("# field-error ").append(e).append('\n');
    }
    for (JTable t : found) {
      TableModel m = t.getModel();
      for (int c = 0; c < m.getColumnCount(); ++c)
        sb.append(c == 0 ? "" : "\t").append(m.getColumnName(c).trim());
      sb.append('\n');
      for (int r = 0; r < m.getRowCount(); ++r) {
        for (int c = 0; c < m.getColumnCount(); ++c) {
          Object v = m.getValueAt(r, c);
          sb.append(c == 0 ? "" : "\t").append(v == null ? "" : v.toString().trim());
        }
        sb.append('\n');
      }
    }
  }
}
