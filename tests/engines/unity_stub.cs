// Stands for the few UnityEngine types docs/exports.md's Unity snippet uses, only so that Mono's
// mcs compiles it and mono runs it in test_engine_exports; nothing of Unity runs. Main gives the
// snippet's MonoBehaviour the .unity.json as its TextAsset, calls Start as Unity would, and prints
// the 27 values it put into RenderSettings.ambientProbe as sh[c, i], c-major, one a line.
using System;
using System.Globalization;
using System.IO;
using System.Linq;
using System.Reflection;
using System.Text.RegularExpressions;

namespace UnityEngine
{
    public class MonoBehaviour {}

    public class TextAsset
    {
        public TextAsset(string text) { this.text = text; }
        public string text { get; }
    }

    // JsonUtility's part the snippet needs: the float[] fields of a flat object.
    public static class JsonUtility
    {
        public static T FromJson<T>(string json) where T : new()
        {
            var result = new T();
            foreach (FieldInfo field in typeof(T).GetFields().Where(f => f.FieldType == typeof(float[])))
            {
                Match array = Regex.Match(json, "\"" + field.Name + "\"\\s*:\\s*\\[([^\\]]*)\\]");
                field.SetValue(result, array.Groups[1].Value.Split(',')
                    .Select(v => float.Parse(v, CultureInfo.InvariantCulture)).ToArray());
            }
            return result;
        }
    }

    public static class RenderSettings
    {
        public static Rendering.SphericalHarmonicsL2 ambientProbe;
    }
}

namespace UnityEngine.Rendering
{
    public struct SphericalHarmonicsL2
    {
        float[] values;
        public float this[int channel, int coefficient]
        {
            get { return values == null ? 0 : values[9 * channel + coefficient]; }
            set
            {
                if (values == null) values = new float[27];
                values[9 * channel + coefficient] = value;
            }
        }
    }
}

static class SnippetRunner
{
    static void Main(string[] args)
    {
        Type type = typeof(SnippetRunner).Assembly.GetTypes().Single(t => t.IsSubclassOf(typeof(UnityEngine.MonoBehaviour)));
        object behaviour = Activator.CreateInstance(type);
        type.GetFields().Single(f => f.FieldType == typeof(UnityEngine.TextAsset))
            .SetValue(behaviour, new UnityEngine.TextAsset(File.ReadAllText(args[0])));
        type.GetMethod("Start", BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public).Invoke(behaviour, null);
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < 9; ++i)
                Console.WriteLine(UnityEngine.RenderSettings.ambientProbe[c, i].ToString("R", CultureInfo.InvariantCulture));
    }
}
